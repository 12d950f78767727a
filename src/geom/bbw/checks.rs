//! The input checks of [`bbw`](super::bbw): options, positions and triangles, handles, and that
//! every connected component holds a handle.

use super::{dist2, twice_signed_area, BbwError, BbwOptions, MeshComponent};

pub(super) fn check_options(options: &BbwOptions) -> Result<(), BbwError> {
    if !(options.tolerance.is_finite() && options.tolerance >= 0.0) {
        return Err(BbwError::Option {
            option: "tolerance",
            problem: format!("{} (expected a finite number ≥ 0)", options.tolerance),
        });
    }
    Ok(())
}

pub(super) fn check_mesh(positions: &[[f64; 2]], triangles: &[[u32; 3]]) -> Result<(), BbwError> {
    if let Some((vertex, &position)) = positions.iter().enumerate().find(|(_, p)| !(p[0].is_finite() && p[1].is_finite())) {
        return Err(BbwError::NonFinite { vertex, position });
    }
    let n = positions.len();
    for (t, &corners) in triangles.iter().enumerate() {
        if let Some(&index) = corners.iter().find(|&&i| i as usize >= n) {
            return Err(BbwError::TriangleIndex {
                triangle: t,
                corners,
                index,
                vertices: n,
            });
        }
        let c = corners.map(|i| positions[i as usize]);
        let longest = (0..3).map(|k| dist2(c[k], c[(k + 1) % 3])).fold(0.0, f64::max);
        // Relative, as in cotan_weights: cotangents depend on shape only.
        if twice_signed_area(c).abs() <= 1e-14 * longest || longest == 0.0 {
            return Err(BbwError::DegenerateTriangle { triangle: t, corners });
        }
    }
    Ok(())
}

pub(super) fn check_handles(n: usize, handles: &[u32]) -> Result<(), BbwError> {
    let mut owner = vec![usize::MAX; n];
    for (k, &v) in handles.iter().enumerate() {
        let slot = owner.get_mut(v as usize).ok_or(BbwError::HandleIndex {
            handle: k,
            vertex: v,
            vertices: n,
        })?;
        if *slot != usize::MAX {
            return Err(BbwError::RepeatedHandle {
                first: *slot,
                second: k,
                vertex: v,
            });
        }
        *slot = k;
    }
    Ok(())
}

/// Unused vertices that are not handles, then components without a handle (union–find over
/// triangle corners).
pub(super) fn check_components(n: usize, triangles: &[[u32; 3]], handles: &[u32]) -> Result<(), BbwError> {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    let mut used = vec![false; n];
    for tri in triangles {
        for &v in tri {
            used[v as usize] = true;
        }
        let mut a = root(&mut parent, tri[0]);
        for &v in &tri[1..] {
            let b = root(&mut parent, v);
            // The smaller index becomes the root, so a root is its component's smallest vertex.
            let (lo, hi) = (a.min(b), a.max(b));
            parent[hi as usize] = lo;
            a = lo;
        }
    }
    let mut is_handle = vec![false; n];
    for &v in handles {
        is_handle[v as usize] = true;
    }
    let unused: Vec<u32> = (0..n as u32).filter(|&v| !used[v as usize] && !is_handle[v as usize]).collect();
    if !unused.is_empty() {
        return Err(BbwError::UnusedVertices { vertices: unused });
    }
    // Per root: component number, vertex and triangle counts, whether it holds a handle.
    let mut number = vec![usize::MAX; n];
    let mut components: Vec<(MeshComponent, bool)> = Vec::new();
    for v in 0..n as u32 {
        let r = root(&mut parent, v) as usize;
        if number[r] == usize::MAX {
            number[r] = components.len();
            let component = MeshComponent {
                index: components.len(),
                first_vertex: v,
                vertices: 0,
                triangles: 0,
            };
            components.push((component, false));
        }
        let entry = &mut components[number[r]];
        entry.0.vertices += 1;
        entry.1 |= is_handle[v as usize];
    }
    for tri in triangles {
        let r = root(&mut parent, tri[0]) as usize;
        components[number[r]].0.triangles += 1;
    }
    let unpinned: Vec<MeshComponent> = components.into_iter().filter(|(_, pinned)| !pinned).map(|(c, _)| c).collect();
    if unpinned.is_empty() {
        Ok(())
    } else {
        Err(BbwError::UnpinnedComponents { components: unpinned })
    }
}

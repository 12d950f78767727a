//! Connected components of a graph given by its edges (union–find with path halving): which
//! vertices a set of triangles or welds joins.

/// The component of each of `n` vertices joined by `edges`, numbered 0, 1, … in the order of each
/// component's lowest vertex (an isolated vertex is a component of its own), and their count.
pub fn component_labels(n: usize, edges: impl IntoIterator<Item = (usize, usize)>) -> (Vec<usize>, usize) {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (a, b) in edges {
        let (a, b) = (root(&mut parent, a), root(&mut parent, b));
        // The lower root wins, so a component's root is its lowest vertex.
        parent[a.max(b)] = a.min(b);
    }
    let mut label = vec![usize::MAX; n];
    let mut count = 0;
    for i in 0..n {
        let r = root(&mut parent, i);
        if label[r] == usize::MAX {
            label[r] = count;
            count += 1;
        }
        label[i] = label[r];
    }
    (label, count)
}

/// The edges of `triangles` that join their vertices (two per triangle suffice).
pub fn triangle_edges(triangles: &[[u32; 3]]) -> impl Iterator<Item = (usize, usize)> + '_ {
    triangles
        .iter()
        .flat_map(|t| [(t[0] as usize, t[1] as usize), (t[0] as usize, t[2] as usize)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_triangles_and_an_isolated_vertex_are_three_components_in_order() {
        let triangles = [[4, 5, 6], [0, 1, 2]];
        let (labels, count) = component_labels(7, triangle_edges(&triangles));
        assert_eq!(count, 3);
        assert_eq!(labels, vec![0, 0, 0, 1, 2, 2, 2]);
    }

    #[test]
    fn a_chain_of_welds_joins_its_ends() {
        let (labels, count) = component_labels(5, [(4, 3), (0, 4), (1, 2)]);
        assert_eq!(count, 2);
        assert_eq!(labels, vec![0, 1, 1, 0, 0]);
    }
}

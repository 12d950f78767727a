//! Test fixtures (STYLE.md §5): seeded random numbers and a tiny layered, textured puppet built
//! programmatically — grid-triangulated rectangles and fan-triangulated discs whose textures vary
//! inside (so interior texture gradients are non-zero) and which overlap.

use crate::picture::Picture;
use crate::puppet::{Joint, Layer, LayerKind, Mesh, Puppet, VertexRef};

/// A small deterministic generator (SplitMix64) so tests need no extra dependency.
pub struct Rng(u64);

impl Rng {
    /// A generator started from `seed`.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A frame-sized texture: `colour(x, y)` where `inside(x, y)`, transparent elsewhere (colours
/// still extended there, as [`Layer::texture`] asks).
pub fn texture(width: u32, height: u32, inside: impl Fn(f32, f32) -> bool, colour: impl Fn(f32, f32) -> [f32; 3]) -> Picture {
    let mut pic = Picture::filled(width, height, [0.0; 4]);
    for y in 0..height {
        for x in 0..width {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let [r, g, b] = colour(px, py);
            let a = if inside(px, py) { 1.0 } else { 0.0 };
            pic.pixels[(y * width + x) as usize] = [r, g, b, a];
        }
    }
    pic
}

/// A layer over the rectangle `[x0, x1] × [y0, y1]`, an `nx × ny` grid of cells, two
/// counter-clockwise triangles each; UVs are frame positions / frame size.
pub fn rect_layer(name: &str, frame: (u32, u32), r: [f32; 4], n: (usize, usize), colour: impl Fn(f32, f32) -> [f32; 3]) -> Layer {
    let [x0, y0, x1, y1] = r;
    let (nx, ny) = n;
    let mut mesh = Mesh::default();
    for j in 0..=ny {
        for i in 0..=nx {
            mesh.vertices
                .push([x0 + (x1 - x0) * i as f32 / nx as f32, y0 + (y1 - y0) * j as f32 / ny as f32]);
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            mesh.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            mesh.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let tex = texture(frame.0, frame.1, |x, y| x >= x0 && x <= x1 && y >= y0 && y <= y1, colour);
    layer(name, frame, mesh, tex)
}

/// A disc layer: centre plus `n` rim vertices, fan-triangulated counter-clockwise.
pub fn disc_layer(name: &str, frame: (u32, u32), c: [f32; 2], radius: f32, n: usize, colour: impl Fn(f32, f32) -> [f32; 3]) -> Layer {
    let mut mesh = Mesh {
        vertices: vec![c],
        triangles: Vec::new(),
    };
    for k in 0..n {
        let th = std::f32::consts::TAU * k as f32 / n as f32;
        mesh.vertices.push([c[0] + radius * th.cos(), c[1] + radius * th.sin()]);
        mesh.triangles.push([0, 1 + k as u32, 1 + ((k + 1) % n) as u32]);
    }
    let tex = texture(frame.0, frame.1, |x, y| (x - c[0]).hypot(y - c[1]) <= radius, colour);
    layer(name, frame, mesh, tex)
}

fn layer(name: &str, frame: (u32, u32), mesh: Mesh, texture: Picture) -> Layer {
    let uvs = mesh
        .vertices
        .iter()
        .map(|v| [v[0] / frame.0 as f32, v[1] / frame.1 as f32])
        .collect();
    Layer {
        name: name.into(),
        kind: LayerKind::Body,
        mesh,
        uvs,
        texture,
    }
}

/// Smoothly varying colour with stripes, so every interior pixel has a texture gradient.
pub fn stripes(base: [f32; 3], period: f32) -> impl Fn(f32, f32) -> [f32; 3] {
    move |x, y| {
        let s = 0.5 + 0.5 * ((x + 0.7 * y) * std::f32::consts::TAU / period).sin();
        let t = 0.5 + 0.5 * ((y - 0.3 * x) * std::f32::consts::TAU / (1.7 * period)).cos();
        [
            base[0] * (0.4 + 0.6 * s),
            base[1] * (0.5 + 0.5 * t),
            (base[2] + 0.3 * s * t).min(1.0),
        ]
    }
}

/// A tiny character on a `48 × 40` frame: torso (rectangle grid), head (disc), two arms
/// (rectangle grids, long along x so they can bend) — four overlapping textured layers, back to
/// front: arm_back, torso, head, arm_front.
pub fn layered_puppet() -> Puppet {
    let f = (48, 40);
    let layers = vec![
        rect_layer("arm_back", f, [6.0, 12.0, 24.0, 17.0], (6, 2), stripes([0.2, 0.5, 0.9], 14.0)),
        rect_layer("torso", f, [16.0, 10.0, 32.0, 34.0], (4, 6), stripes([0.9, 0.6, 0.2], 16.0)),
        disc_layer("head", f, [24.0, 9.0], 6.5, 12, stripes([0.3, 0.8, 0.3], 11.0)),
        rect_layer("arm_front", f, [24.0, 20.0, 43.0, 25.0], (6, 2), stripes([0.8, 0.2, 0.5], 13.0)),
    ];
    Puppet {
        width: f.0,
        height: f.1,
        layers,
        root: 1,
        joints: Vec::new(),
        rig: None,
    }
}

/// [`layered_puppet`] with the front arm hinged to the torso at a shared rest point (24, 20).
pub fn hinged_puppet() -> Puppet {
    let mut puppet = layered_puppet();
    let torso = puppet.layer_index("torso").unwrap();
    let arm = puppet.layer_index("arm_front").unwrap();
    weld(&mut puppet, torso, arm, [24.0, 20.0]);
    puppet
}

/// Joins layer `child` to layer `parent` at their vertices nearest `point`.
pub fn weld(puppet: &mut Puppet, parent: usize, child: usize, point: [f32; 2]) {
    let find = |l: usize| {
        let v = &puppet.layers[l].mesh.vertices;
        (0..v.len())
            .min_by(|&a, &b| {
                let d = |i: usize| (v[i][0] - point[0]).powi(2) + (v[i][1] - point[1]).powi(2);
                d(a).total_cmp(&d(b))
            })
            .unwrap() as u32
    };
    let (a, b) = (find(parent), find(child));
    puppet.joints.push(Joint {
        a: VertexRef { layer: parent, vertex: a },
        b: VertexRef { layer: child, vertex: b },
    });
}

/// An untrained model of [`layered_puppet`] whose network reads 16² input, and its device: for
/// tests of what goes in and out of a model, not of what it learned.
pub fn tiny_model() -> (crate::model::Model, burn::tensor::Device) {
    untrained_model(layered_puppet(), 16)
}

/// An untrained model of `puppet` whose network reads `input`² frames (its decoder's last layer
/// is zero, so it decodes the rest pose), and its device.
pub fn untrained_model(puppet: Puppet, input: usize) -> (crate::model::Model, burn::tensor::Device) {
    let device = crate::backend::device();
    let config = crate::model::deformation::DeformationNetConfig::new(puppet.free_vertices().len()).with_input_size(input);
    (crate::model::Model::new(config, puppet, &device).unwrap(), device)
}

/// [`layered_puppet`] with its front arm made an accessory (a sleeve, say) and rigged with the
/// default options: the torso is its parent.
pub fn dressed_puppet() -> Puppet {
    let mut p = layered_puppet();
    let arm = p.layer_index("arm_front").unwrap();
    p.layers[arm].kind = LayerKind::Accessory;
    let mesh = crate::puppet::build::BuildOptions::default().mesh_options(p.width, p.height);
    crate::rig::rig_puppet(&p, &Default::default(), &mesh, &Default::default(), &crate::progress::Silent).unwrap()
}

/// The largest distance between corresponding points of two poses (pixels).
pub fn largest_distance(a: &[[f32; 2]], b: &[[f32; 2]]) -> f32 {
    a.iter().zip(b).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f32::max)
}

/// `vertices` flattened to `[x0, y0, x1, y1, …]` with each coordinate moved by a uniform amount
/// in `[-amount, amount)` (seeded), so that no pixel centre lies exactly on an edge.
pub fn jittered(vertices: &[[f32; 2]], seed: u64, amount: f64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    vertices
        .iter()
        .flatten()
        .map(|&c| c as f64 + rng.uniform(-amount, amount))
        .collect()
}

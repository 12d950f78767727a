//! The posing engine: a puppet built from real layered artwork, posed at random with the
//! project's own machinery — limbs turned about their joints, ARAP drags, squash and stretch,
//! accessories carried by their rigs, draw order kept by the renderer — with the exact truth of
//! every pose: each template vertex's place and visibility, and the layer in front at each
//! pixel. This is AutoFlow's layered rendering with drawn characters (prior-design.md §2–3): the
//! data a character-agnostic prior learns from. It sits below training so a trainer can pose
//! characters on the fly; `puppet prior data` writes its poses to disk.
//!
//! A pose is a function of the puppet, the settings and a seed: [`sample`] draws the rigid part,
//! [`drag`] the bends, [`truth`] the labels and visibility, [`write`](mod@write) the folder of a
//! character.

pub mod drag;
pub mod sample;
pub mod truth;
pub mod write;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::puppet::limbs::{limbs, Limb};
use crate::puppet::Puppet;
use crate::render::{straight_picture, Background, Params, SoftRasterizer};
use crate::rig::deform::RigMap;
use crate::rng::Rng;
use drag::{drag_layers, DragLayer};
use truth::LayerCoverage;

pub use truth::{surface_points, SurfacePoint, NO_LAYER};

/// How far the engine moves a character from its rest pose. Every range is drawn uniformly,
/// either way.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EngineSettings {
    /// Each limb turned about its joint by up to this many degrees.
    pub max_degrees: f32,
    /// Layers dragged per pose (fewer when the puppet has fewer that can be).
    pub drags: usize,
    /// How far a drag pulls a layer's end, as a share of the figure's larger side.
    pub drag: f32,
    /// Squash and stretch: the figure's height times up to `1 ± squash`, its width divided by
    /// the same.
    pub squash: f32,
    /// The whole figure turned by up to this many degrees.
    pub turn_degrees: f32,
    /// The whole figure scaled by up to this share, about the frame's centre.
    pub scale: f32,
    /// The whole figure shifted by up to this share of the frame's width and height.
    pub shift: f32,
}

impl Default for EngineSettings {
    /// Poses a drawn character could take: limbs within ±35°, two drags of up to 4 % of the
    /// figure, ±10 % squash, and small global moves.
    fn default() -> Self {
        EngineSettings {
            max_degrees: 35.0,
            drags: 2,
            drag: 0.04,
            squash: 0.1,
            turn_degrees: 5.0,
            scale: 0.05,
            shift: 0.03,
        }
    }
}

impl EngineSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first one out of range.
    pub fn validate(&self) -> Result<()> {
        let check = |key: &str, value: f32, range: std::ops::RangeInclusive<f32>| {
            if value.is_finite() && range.contains(&value) {
                Ok(())
            } else {
                Err(Error::setting(
                    format!("engine.{key}"),
                    value,
                    format!("from {} to {}", range.start(), range.end()),
                ))
            }
        };
        check("max_degrees", self.max_degrees, 0.0..=180.0)?;
        check("drag", self.drag, 0.0..=0.5)?;
        check("squash", self.squash, 0.0..=0.5)?;
        check("turn_degrees", self.turn_degrees, 0.0..=180.0)?;
        check("scale", self.scale, 0.0..=0.5)?;
        check("shift", self.shift, 0.0..=0.5)?;
        if self.drags > 64 {
            return Err(Error::setting("engine.drags", self.drags, "from 0 to 64"));
        }
        Ok(())
    }
}

/// One posed frame and its truth.
#[derive(Clone, Debug, PartialEq)]
pub struct PosedFrame {
    /// The crisp render of the pose on a transparent background, the puppet's frame size.
    pub picture: Picture,
    /// Every template vertex in frame pixels, global numbering ([`Puppet::vertex_offsets`]).
    pub vertices: Vec<[f32; 2]>,
    /// Per vertex: inside the frame, and not covered by a layer drawn in front of its own.
    pub visible: Vec<bool>,
    /// Per pixel, row-major: the index of the layer in front there, or [`NO_LAYER`].
    pub labels: Vec<u16>,
}

/// Poses one puppet: everything fixed about it is prepared once (limbs, factored ARAP systems,
/// the rig's map, the rasterizers), so a pose costs its solves and renders.
pub struct PoseEngine {
    puppet: Puppet,
    settings: EngineSettings,
    limbs: Vec<Limb>,
    drags: Vec<DragLayer>,
    rig: Option<RigMap>,
    raster: SoftRasterizer,
    coverage: LayerCoverage,
    offsets: Vec<usize>,
    figure: f32,
}

impl PoseEngine {
    /// The engine for `puppet` with `settings`.
    ///
    /// # Errors
    /// [`Error::Setting`] for settings out of range or a puppet of more layers than labels can
    /// tell apart; as [`SoftRasterizer::new`] for a malformed layer.
    pub fn new(puppet: &Puppet, settings: EngineSettings) -> Result<Self> {
        settings.validate()?;
        if puppet.layers.len() >= usize::from(NO_LAYER) {
            return Err(Error::setting("layers", puppet.layers.len(), format!("fewer than {NO_LAYER}")));
        }
        Ok(PoseEngine {
            limbs: limbs(puppet),
            drags: drag_layers(puppet),
            rig: puppet.rig.as_ref().map(|rig| RigMap::new(puppet, rig)),
            raster: SoftRasterizer::new(puppet)?,
            coverage: LayerCoverage::new(puppet)?,
            offsets: puppet.vertex_offsets(),
            figure: sample::figure_size(&puppet.rest_vertices()),
            puppet: puppet.clone(),
            settings,
        })
    }

    /// The puppet posed.
    pub fn puppet(&self) -> &Puppet {
        &self.puppet
    }

    /// The limbs turned about their joints.
    pub fn limbs(&self) -> &[Limb] {
        &self.limbs
    }

    /// The layers a drag may bend.
    pub fn drag_layers(&self) -> impl Iterator<Item = usize> + '_ {
        self.drags.iter().map(|d| d.layer)
    }

    /// The vertices of pose `seed` (global numbering, frame pixels): limbs turned root first,
    /// layers dragged, accessories placed by the rig, then the whole figure squashed, turned,
    /// scaled and shifted.
    pub fn vertices(&self, seed: u64) -> Vec<[f32; 2]> {
        let s = &self.settings;
        let mut rng = Rng::new(seed);
        let mut pose = self.puppet.rest_vertices();
        sample::turn_limbs(&self.limbs, &mut pose, s.max_degrees, &mut rng);
        let mut candidates: Vec<&DragLayer> = self.drags.iter().collect();
        for _ in 0..s.drags.min(candidates.len()) {
            let layer = candidates.swap_remove(rng.below(candidates.len()));
            layer.drag(&self.puppet, &mut pose, self.offsets[layer.layer], s.drag * self.figure, &mut rng);
        }
        if let Some(map) = &self.rig {
            map.apply(&mut pose);
        }
        sample::squash_and_turn(&mut pose, s.squash, s.turn_degrees, &mut rng);
        sample::scale_and_shift(&mut pose, self.puppet.width, self.puppet.height, s.scale, s.shift, &mut rng);
        pose
    }

    /// Pose `seed` with its frame and truth.
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`]: a pose with a coordinate that is not finite.
    pub fn pose(&self, seed: u64) -> Result<PosedFrame> {
        self.frame(self.vertices(seed))
    }

    /// The frame and truth of the pose `vertices` (global numbering, frame pixels): the rest
    /// pose's, or any other.
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`]: a coordinate that is not finite.
    pub fn frame(&self, vertices: Vec<[f32; 2]>) -> Result<PosedFrame> {
        let (w, h) = (self.puppet.width, self.puppet.height);
        let flat: Vec<f32> = vertices.iter().flatten().copied().collect();
        let frame = self
            .raster
            .forward(&flat, 1, w as usize, h as usize, &Params::crisp(Background::Transparent))?;
        let labels = self.coverage.labels(&vertices, w, h)?;
        Ok(PosedFrame {
            picture: straight_picture(&frame.image, w, h),
            visible: truth::visible(&vertices, &self.offsets, &labels, w, h),
            vertices,
            labels,
        })
    }

    /// The poses of `seeds`, made in parallel.
    ///
    /// # Errors
    /// As [`PoseEngine::pose`].
    pub fn poses(&self, seeds: &[u64]) -> Result<Vec<PosedFrame>> {
        seeds.par_iter().map(|&seed| self.pose(seed)).collect()
    }
}

/// The seed of the `k`-th pose of a run seeded `seed`: independent streams, so pose `k` is the
/// same whatever the number of poses.
pub fn pose_seed(seed: u64, k: usize) -> u64 {
    Rng::new(seed).fork(k as u64).next_u64()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::similarity::Similarity;
    use crate::test_util::{dressed_puppet, hinged_puppet, layered_puppet, weld};

    /// A character with limbs of two levels: the torso, the front arm on it, the head on it.
    fn limbed_puppet() -> Puppet {
        let mut p = hinged_puppet();
        let (torso, head, back) = (1, 2, 0);
        weld(&mut p, torso, head, [24.0, 14.0]);
        weld(&mut p, torso, back, [18.0, 14.5]);
        p
    }

    /// Bilinear sample of a straight-alpha picture at `(x, y)` in its pixel space (texel centres
    /// at +0.5), clamped at the border.
    fn bilinear(pic: &Picture, x: f32, y: f32) -> [f32; 4] {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let at = |dx: f32, dy: f32| {
            let cx = (x0 + dx).clamp(0.0, pic.width as f32 - 1.0) as u32;
            let cy = (y0 + dy).clamp(0.0, pic.height as f32 - 1.0) as u32;
            pic.get(cx, cy)
        };
        let (a, b, c, d) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0));
        std::array::from_fn(|k| (a[k] * (1.0 - tx) + b[k] * tx) * (1.0 - ty) + (c[k] * (1.0 - tx) + d[k] * tx) * ty)
    }

    /// Checks the engine's truth on `puppet`: a visible vertex well inside its layer's opaque
    /// area shows, in the frame, its texture's colour at its UV. Returns how many were checked.
    fn assert_truth(puppet: &Puppet, seeds: std::ops::Range<u64>) -> usize {
        let engine = PoseEngine::new(puppet, EngineSettings::default()).unwrap();
        let offsets = puppet.vertex_offsets();
        let (w, h) = (puppet.width as i64, puppet.height as i64);
        let (mut checked, mut agree) = (0usize, 0usize);
        for seed in seeds {
            let posed = engine.pose(seed).unwrap();
            for (l, layer) in puppet.layers.iter().enumerate() {
                let tex = &layer.texture;
                for (v, &uv) in layer.uvs.iter().enumerate() {
                    let g = offsets[l] + v;
                    let p = posed.vertices[g];
                    if !posed.visible[g] {
                        continue;
                    }
                    // Strictly inside: the frame's 3×3 pixels round it are all this layer's, and
                    // the texture is opaque round the UV.
                    let (x, y) = (p[0].floor() as i64, p[1].floor() as i64);
                    let own = (-1..=1).all(|dy| {
                        (-1..=1).all(|dx| {
                            let (qx, qy) = (x + dx, y + dy);
                            (0..w).contains(&qx) && (0..h).contains(&qy) && usize::from(posed.labels[(qy * w + qx) as usize]) == l
                        })
                    });
                    let (tx, ty) = (uv[0] * tex.width as f32, uv[1] * tex.height as f32);
                    let opaque = (-1..=1).all(|dy| (-1..=1).all(|dx| bilinear(tex, tx + dx as f32, ty + dy as f32)[3] > 0.99));
                    if !(own && opaque) {
                        continue;
                    }
                    let (want, got) = (bilinear(tex, tx, ty), bilinear(&posed.picture, p[0], p[1]));
                    checked += 1;
                    agree += usize::from((0..3).all(|c| (want[c] - got[c]).abs() <= 0.1));
                }
            }
        }
        assert!(checked > 0, "no vertex was strictly inside its layer");
        assert!(
            agree as f64 >= 0.95 * checked as f64,
            "{agree} of {checked} posed vertices show their texture's colour"
        );
        checked
    }

    #[test]
    fn a_posed_vertex_lands_on_the_pixel_its_texture_coordinate_says() {
        assert!(assert_truth(&limbed_puppet(), 0..6) > 20);
        assert!(assert_truth(&dressed_puppet(), 0..4) > 10);
    }

    #[test]
    fn a_seed_gives_one_pose_and_another_seed_another() {
        let engine = PoseEngine::new(&limbed_puppet(), EngineSettings::default()).unwrap();
        let (a, b, c) = (engine.pose(7).unwrap(), engine.pose(7).unwrap(), engine.pose(8).unwrap());
        assert!(a == b, "one seed, one frame");
        assert_ne!(a.vertices, c.vertices);
        assert_ne!(a.picture, c.picture);
        let seeds: Vec<u64> = (0..3).map(|k| pose_seed(3, k)).collect();
        let batch = engine.poses(&seeds).unwrap();
        assert_eq!(batch[1], engine.pose(pose_seed(3, 1)).unwrap(), "a batch is its poses");
        assert_ne!(seeds[0], seeds[1]);
        assert_ne!(a.vertices, engine.puppet().rest_vertices(), "a pose is not the rest pose");
    }

    #[test]
    fn joints_stay_welded_and_no_body_triangle_turns_over() {
        let puppet = limbed_puppet();
        let settings = EngineSettings {
            drags: 4,
            drag: 0.08,
            ..EngineSettings::default()
        };
        let engine = PoseEngine::new(&puppet, settings.clone()).unwrap();
        assert_eq!(engine.limbs().len(), 3);
        assert!(engine.drag_layers().count() >= 3, "every hinged layer can be dragged");
        let rest = puppet.rest_vertices();
        let gap = |pose: &[[f32; 2]], j: &crate::puppet::Joint| {
            let (a, b) = (pose[puppet.global_index(j.a)], pose[puppet.global_index(j.b)]);
            (a[0] - b[0]).hypot(a[1] - b[1])
        };
        let offsets = puppet.vertex_offsets();
        let unbent = PoseEngine::new(
            &puppet,
            EngineSettings {
                squash: 0.0,
                ..settings.clone()
            },
        )
        .unwrap();
        let mut bent = false;
        for seed in 0..30 {
            let pose = engine.vertices(seed);
            let unsquashed = unbent.vertices(seed);
            for j in &puppet.joints {
                // The global squash and scale stretch a gap there was at rest, and nothing else.
                let allowed = gap(&rest, j) * (1.0 + settings.squash) * (1.0 + settings.scale);
                assert!(gap(&pose, j) <= allowed + 0.5, "seed {seed}: a joint came apart");
            }
            for (l, layer) in puppet.layers.iter().enumerate() {
                let posed = crate::puppet::Mesh {
                    vertices: pose[offsets[l]..offsets[l + 1]].to_vec(),
                    triangles: layer.mesh.triangles.clone(),
                };
                assert!(
                    posed.check_invariants().is_ok(),
                    "seed {seed}: layer {:?}: {:?}",
                    layer.name,
                    posed.check_invariants()
                );
                // A drag bends: the layer is no longer a similarity of its rest shape (the
                // squash is not one either, so it is turned off here).
                if let Some(fit) = Similarity::fit(&layer.mesh.vertices, &unsquashed[offsets[l]..offsets[l + 1]]) {
                    bent |= layer
                        .mesh
                        .vertices
                        .iter()
                        .zip(&unsquashed[offsets[l]..offsets[l + 1]])
                        .any(|(&r, q)| {
                            let p = fit.apply(r);
                            (p[0] - q[0]).hypot(p[1] - q[1]) > 0.1
                        });
                }
            }
        }
        assert!(bent, "no drag bent a layer in thirty poses");
    }

    #[test]
    fn accessories_follow_their_rig_and_settings_out_of_range_are_named() {
        let puppet = dressed_puppet();
        // Without the global moves (which carry the whole picture, accessories included) a
        // pose's accessories are where the rig puts them on its body.
        let still = EngineSettings {
            squash: 0.0,
            turn_degrees: 0.0,
            scale: 0.0,
            shift: 0.0,
            ..EngineSettings::default()
        };
        let engine = PoseEngine::new(&puppet, still).unwrap();
        let mut pose = engine.vertices(2);
        let placed = pose.clone();
        RigMap::new(&puppet, puppet.rig.as_ref().unwrap()).apply(&mut pose);
        assert!(crate::test_util::largest_distance(&pose, &placed) < 1e-4);
        assert_ne!(placed, puppet.rest_vertices(), "the body moved, and the accessory with it");
        let bad = EngineSettings {
            squash: 2.0,
            ..EngineSettings::default()
        };
        let err = PoseEngine::new(&layered_puppet(), bad).err().unwrap().to_string();
        assert!(err.contains("engine.squash"), "{err}");
    }
}

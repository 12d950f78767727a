//! What `puppet eval-rig` reports: the scores of each way of moving accessories, per edit,
//! character and set, and the report's table.

use std::path::PathBuf;

use serde::Serialize;

/// The scores of one way of moving the accessories under one edit.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Scores {
    /// Share of the hidden body outline still covered.
    pub occlusion_kept: f64,
    /// Deepest exposure of the hidden outline, pixels.
    pub deepest_exposure: f64,
    /// Runs of more than 4 px of exposed outline.
    pub leak_blobs: usize,
    /// Share of the outline each accessory hid of the body layer it follows still covered by
    /// those accessories (module doc).
    pub own_occlusion_kept: f64,
    /// Deepest exposure of that outline, pixels.
    pub own_deepest_exposure: f64,
    /// Median over accessories of overlap area after / before.
    pub overlap_retention: f64,
    /// Mean distance between the two places each overlap anchor goes, pixels.
    pub anchor_drift: f64,
    /// Accessory triangles turned over.
    pub inverted: usize,
    /// Enclosed holes in accessories' coverage not there at rest.
    pub new_holes: usize,
    /// 95th percentile of the change of distance between coincident boundaries, pixels (`None`
    /// without coincident constraints).
    pub seam_change_p95: Option<f64>,
    /// 95th percentile of the accessory triangles' larger stretch.
    pub stretch_p95: f64,
}

/// One edit of one character: the rig and the two baselines.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EditReport {
    /// The edit's name.
    pub edit: String,
    /// The accessory rig.
    pub rig: Scores,
    /// Accessories left at rest.
    pub unchanged: Scores,
    /// Accessories stuck to the body under them.
    pub sticker: Scores,
}

/// DAG correctness of one character.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DagScore {
    /// Accessories with a true parent.
    pub judged: usize,
    /// Whose parent is the truth.
    pub strict: usize,
    /// Whose parent is the truth or hangs from it.
    pub lenient: usize,
    /// Accessories whose parent differs from the truth: (layer, chosen, true).
    pub wrong: Vec<(String, String, String)>,
}

/// One way of moving the accessories along a synthetic sequence's true body motion, against
/// the accessories' true places.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MotionScores {
    /// Mean distance of the accessory vertices from their true places, pixels.
    pub accessory_error: f64,
    /// Mean, over frames and accessories, of the IoU of an accessory's coverage with its true
    /// coverage.
    pub accessory_iou: f64,
    /// The worst of the pose scores over the frames.
    pub scores: Scores,
}

/// A synthetic character's accessories along its sequence's true body motion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionReport {
    /// Frames scored.
    pub frames: usize,
    /// The accessory rig.
    pub rig: MotionScores,
    /// Accessories left at rest.
    pub unchanged: MotionScores,
    /// Accessories stuck to the body under them.
    pub sticker: MotionScores,
    /// The accessories where the generator drew them: what the pose scores are for the true
    /// motion itself (a sleeve swinging with its arm uncovers the torso outline it hid at rest).
    pub truth: Scores,
}

/// One character's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CharacterReport {
    /// The character's folder name.
    pub name: String,
    /// Its layers and accessories.
    pub layers: usize,
    /// Its accessories.
    pub accessories: usize,
    /// DAG correctness, if the character has a truth file.
    pub dag: Option<DagScore>,
    /// Per edit.
    pub edits: Vec<EditReport>,
    /// For a synthetic sequence, along its true motion ([`super::evaluate_motion`]).
    pub motion: Option<MotionReport>,
}

/// The whole set's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RigReport {
    /// Per character.
    pub characters: Vec<CharacterReport>,
}

/// One character of a rig evaluation set.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Member {
    /// The subfolder's name.
    pub name: String,
    /// The folder holding `character.toml`.
    pub artwork: PathBuf,
    /// For a synthetic sequence (`puppet synth --accessories`), its folder, which holds
    /// `truth.json` and the artwork in `template/`.
    pub sequence: Option<PathBuf>,
}

impl Scores {
    /// The worst of `scores`, score by score: the lowest shares, the largest distances and
    /// stretches, and the counts summed — how one way of moving accessories did over a
    /// character's edits, or over the set.
    pub fn worst<'a>(scores: impl IntoIterator<Item = &'a Scores>) -> Self {
        let mut s = Scores {
            occlusion_kept: 1.0,
            own_occlusion_kept: 1.0,
            overlap_retention: f64::INFINITY,
            ..Scores::default()
        };
        for x in scores {
            s.occlusion_kept = s.occlusion_kept.min(x.occlusion_kept);
            s.deepest_exposure = s.deepest_exposure.max(x.deepest_exposure);
            s.leak_blobs += x.leak_blobs;
            s.own_occlusion_kept = s.own_occlusion_kept.min(x.own_occlusion_kept);
            s.own_deepest_exposure = s.own_deepest_exposure.max(x.own_deepest_exposure);
            s.overlap_retention = s.overlap_retention.min(x.overlap_retention);
            s.anchor_drift = s.anchor_drift.max(x.anchor_drift);
            s.inverted += x.inverted;
            s.new_holes += x.new_holes;
            s.seam_change_p95 = match (s.seam_change_p95, x.seam_change_p95) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            s.stretch_p95 = s.stretch_p95.max(x.stretch_p95);
        }
        if s.overlap_retention.is_infinite() {
            s.overlap_retention = 1.0;
        }
        s
    }

    /// The column titles of [`Scores::row`].
    pub fn header() -> String {
        format!(
            "{:>9} {:>7} {:>5} {:>8} {:>8} {:>7} {:>6} {:>5} {:>5} {:>7} {:>7}",
            "occl.kept", "deepest", "leaks", "own.kept", "own.deep", "overlap", "drift", "inv", "holes", "seam95", "stretch"
        )
    }

    /// One row of the report table.
    pub fn row(&self) -> String {
        format!(
            "{:>8.2}% {:>7.2} {:>5} {:>7.2}% {:>8.2} {:>7.3} {:>6.2} {:>5} {:>5} {:>7} {:>7.2}",
            100.0 * self.occlusion_kept,
            self.deepest_exposure,
            self.leak_blobs,
            100.0 * self.own_occlusion_kept,
            self.own_deepest_exposure,
            self.overlap_retention,
            self.anchor_drift,
            self.inverted,
            self.new_holes,
            self.seam_change_p95.map_or("-".into(), |v| format!("{v:.2}")),
            self.stretch_p95
        )
    }
}

impl RigReport {
    /// DAG correctness over the set: (judged, strict, lenient).
    pub fn dag(&self) -> (usize, usize, usize) {
        self.characters
            .iter()
            .filter_map(|c| c.dag.as_ref())
            .fold((0, 0, 0), |(j, s, l), d| (j + d.judged, s + d.strict, l + d.lenient))
    }

    /// The report as a table: per character and over the set, each way of moving accessories.
    pub fn table(&self) -> String {
        let header = format!("{:<22} {:>9} | {:<9} {}\n", "character", "DAG s/l", "method", Scores::header());
        let mut out = header;
        fn method(report: &EditReport, k: usize) -> &Scores {
            match k {
                0 => &report.rig,
                1 => &report.sticker,
                _ => &report.unchanged,
            }
        }
        let names = ["rig", "sticker", "unchanged"];
        for c in &self.characters {
            let dag = c
                .dag
                .as_ref()
                .map_or("-".to_string(), |d| format!("{}/{}/{}", d.strict, d.lenient, d.judged));
            for (k, name) in names.iter().enumerate() {
                let summary = Scores::worst(c.edits.iter().map(|e| method(e, k)));
                let label = if k == 0 { c.name.as_str() } else { "" };
                let dag = if k == 0 { dag.as_str() } else { "" };
                out.push_str(&format!("{label:<22} {dag:>9} | {name:<9} {}\n", summary.row()));
            }
        }
        let (judged, strict, lenient) = self.dag();
        for (k, name) in names.iter().enumerate() {
            let summary = Scores::worst(self.characters.iter().flat_map(|c| c.edits.iter().map(move |e| method(e, k))));
            let label = if k == 0 { "all" } else { "" };
            let dag = if k == 0 {
                format!("{strict}/{lenient}/{judged}")
            } else {
                String::new()
            };
            out.push_str(&format!("{label:<22} {dag:>9} | {name:<9} {}\n", summary.row()));
        }
        let motions: Vec<(&str, &MotionReport)> = self
            .characters
            .iter()
            .filter_map(|c| c.motion.as_ref().map(|m| (c.name.as_str(), m)))
            .collect();
        if !motions.is_empty() {
            out.push_str(&format!(
                "\n{:<22} {:>9} | {:<9} {:>6} {:>6} {}\n",
                "true motion",
                "frames",
                "method",
                "acc.px",
                "IoU",
                Scores::header()
            ));
            fn pick(m: &MotionReport, k: usize) -> &MotionScores {
                match k {
                    0 => &m.rig,
                    1 => &m.sticker,
                    _ => &m.unchanged,
                }
            }
            for (name, m) in &motions {
                let truth = MotionScores {
                    accessory_error: 0.0,
                    accessory_iou: 1.0,
                    scores: m.truth.clone(),
                };
                for (k, method) in names.iter().chain(&["truth"]).enumerate() {
                    let s = if k < names.len() { pick(m, k) } else { &truth };
                    let (label, frames) = if k == 0 {
                        (*name, m.frames.to_string())
                    } else {
                        ("", String::new())
                    };
                    out.push_str(&format!(
                        "{label:<22} {frames:>9} | {method:<9} {:>6.2} {:>6.3} {}\n",
                        s.accessory_error,
                        s.accessory_iou,
                        s.scores.row()
                    ));
                }
            }
        }
        out
    }
}

//! The one training harness every trainer runs in (the deformation network, the appearance
//! stage, the parts' correspondence network): it claims and locks the run folder, refuses a
//! fresh run into a folder with a checkpoint and a resume that does not match its checkpoint,
//! takes the steps, stops on a loss that is not finite, scores the held-out data, logs, plots,
//! checkpoints atomically and reports progress. A trainer supplies only what a step is, through
//! [`Run`].
//!
//! Checkpoints are written with the steps done so far at the start (0, the untrained weights,
//! so a run that diverges at once has one to resume from), after every `checkpoint_every`
//! completed steps, and at the end; each holds only weights made by steps whose losses were
//! finite. A step's outcome is a function of its number and the checkpointed state, so a run
//! resumed from a checkpoint takes the steps an uninterrupted one would.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::checkpoint::{self, Checkpoint, CheckpointState};
use super::log::{CsvRow, TrainLog};
use crate::atomic_file::{record, write_atomic, Outputs};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;

/// A trainer as the harness drives it: its steps and its state.
pub trait Run {
    /// One step's numbers in the log.
    type Row: CsvRow;

    /// The run folder's files that always hold the newest of the checkpoint's files of the same
    /// names, so the model can be used while it trains.
    const NEWEST: &'static [&'static str];

    /// Takes optimiser step `step` (from 0; it picks the batch and seeds the sampling, so that a
    /// resumed run takes the same step) and returns its row, held-out columns unmeasured.
    ///
    /// # Errors
    /// Whatever the step reports.
    fn step(&mut self, step: u64) -> Result<Self::Row>;

    /// The losses of `row` as text, if one that must be finite is not.
    fn non_finite(&self, row: &Self::Row) -> Option<String>;

    /// Fills the held-out columns of `row`, the row of step `step` (from 0).
    ///
    /// # Errors
    /// Whatever scoring reports.
    fn held_out(&mut self, step: u64, row: &mut Self::Row) -> Result<()>;

    /// The progress line after `row`.
    fn message(&self, row: &Self::Row) -> String;

    /// The checkpoint's files (name, bytes); `dir` names them in errors.
    ///
    /// # Errors
    /// [`Error::Format`] if a network or optimiser cannot be encoded.
    fn state_files(&self, dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>>;

    /// Takes up the state of `checkpoint`.
    ///
    /// # Errors
    /// [`Error::Format`], [`Error::Io`] or [`Error::Limit`] naming a file of the checkpoint that
    /// does not fit, cannot be read or is too large.
    fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()>;

    /// The loss plot of the log's `rows`.
    fn plot(&self, rows: &[Self::Row]) -> Picture;
}

/// How far to go and how often to look: the steps of a run.
#[derive(Clone, Debug)]
pub struct Plan<'a> {
    /// The progress stage's name.
    pub stage: &'a str,
    /// Steps of the whole run.
    pub steps: u64,
    /// Pause after this many steps in total (checkpointed, resumable).
    pub pause_at: Option<u64>,
    /// Steps between checkpoints.
    pub checkpoint_every: u64,
    /// Steps between held-out scores (also scored at the last step).
    pub eval_every: u64,
    /// Examples (frames, pairs) per step, for the rate.
    pub per_step: usize,
    /// The log CSV.
    pub log: PathBuf,
    /// The loss plot PNG.
    pub plot: PathBuf,
}

impl Plan<'_> {
    /// The step count this session stops at.
    pub fn stop(&self) -> u64 {
        self.pause_at.map_or(self.steps, |p| p.min(self.steps))
    }
}

/// What a session did.
#[derive(Clone, Debug)]
pub struct Summary<R> {
    /// Steps done in total (including those before a resume).
    pub steps: u64,
    /// Whether all of the plan's steps are done.
    pub finished: bool,
    /// The last step's row of this session.
    pub last: Option<R>,
    /// Training seconds in total (including those before a resume).
    pub seconds: f64,
    /// Examples per second over this session's steps.
    pub per_second: f64,
}

/// A run folder claimed for a run: locked for as long as this lives, with its previous
/// checkpoint read and checked.
pub struct RunFolder {
    dir: PathBuf,
    config: serde_json::Value,
    previous: Option<Checkpoint>,
    /// Holds the folder's lock until the run ends.
    _outputs: Outputs,
}

impl RunFolder {
    /// Locks `dir` (making it if missing), then reads its newest checkpoint: a fresh run
    /// (`resume` false) needs none, and a folder it fills must be empty or puppet's (or
    /// `force`); a resume needs one whose config is `config` but for the keys `may_change`
    /// (and `output`, as a moved run folder is the same run).
    ///
    /// # Errors
    /// [`Error::InUse`] while another process fills `dir`; [`Error::WouldOverwrite`] for a
    /// folder puppet did not make; [`Error::RunExists`] for a checkpoint when not resuming;
    /// [`Error::Resume`] for a resume without a checkpoint or with another config. None of these
    /// changes a file.
    pub fn claim(dir: &Path, config: serde_json::Value, may_change: &[&str], resume: bool, force: bool) -> Result<Self> {
        // A resume is checked against the checkpoint instead: a folder holding one of puppet's
        // checkpoints is puppet's, even moved to where no manifest lists it.
        let outputs = Outputs::new(force || resume);
        outputs.claim_folder(dir)?;
        let previous = checkpoint::latest(dir)?.map(|c| checkpoint::load(&c)).transpose()?;
        checkpoint::check_run(dir, previous.as_ref(), resume)?;
        if let Some(c) = &previous {
            checkpoint::check_same_config(dir, c, &config, may_change)?;
        }
        Ok(RunFolder {
            dir: dir.to_path_buf(),
            config,
            previous,
            _outputs: outputs,
        })
    }

    /// The checkpoint a resume starts from.
    pub fn previous(&self) -> Option<&Checkpoint> {
        self.previous.as_ref()
    }

    /// Gives `run` the state of the checkpoint it resumes from, if any.
    ///
    /// # Errors
    /// As [`Run::restore`].
    pub fn restore<R: Run>(&self, run: &mut R) -> Result<()> {
        self.previous.as_ref().map_or(Ok(()), |c| run.restore(c))
    }

    /// Runs `run` (restored by [`RunFolder::restore`] when resuming) through `plan`'s steps from
    /// where the checkpoint left off, then releases the folder.
    ///
    /// # Errors
    /// [`Error::Diverged`] naming the newest checkpoint when a step's loss is not finite;
    /// whatever a step, scoring or writing reports.
    pub fn train<R: Run>(self, run: &mut R, plan: &Plan, progress: &dyn Progress) -> Result<Summary<R::Row>> {
        let (mut step, mut elapsed) = self.previous.as_ref().map_or((0, 0.0), |c| (c.state.step, c.state.elapsed));
        if self.previous.is_none() {
            // Listed in its parent's manifest, so a later fresh run may fill it again.
            record(&std::path::absolute(&self.dir).map_err(|e| Error::io(&self.dir, e))?)?;
        }
        let mut log = TrainLog::<R::Row>::open(&plan.log, step)?;
        let stop = plan.stop();
        progress.stage(plan.stage, plan.steps);
        progress.resume(step);
        let (started, first) = (Instant::now(), step);
        if step == 0 {
            self.save(run, plan, 0, 0.0, &log)?;
        }
        let mut last = None;
        while step < stop && !progress.stop_requested() {
            let t0 = Instant::now();
            let mut row = run.step(step)?;
            if let Some(losses) = run.non_finite(&row) {
                return Err(Error::Diverged {
                    step: step + 1,
                    losses,
                    checkpoint: checkpoint::latest(&self.dir)?,
                });
            }
            elapsed += t0.elapsed().as_secs_f64();
            row.set_seconds(elapsed);
            if (step + 1) % plan.eval_every == 0 || step + 1 == plan.steps {
                run.held_out(step, &mut row)?;
            }
            step += 1;
            log.push(row)?;
            last = Some(row);
            progress.advance(1);
            progress.message(&run.message(&row));
            if step % plan.checkpoint_every == 0 && step < stop {
                self.save(run, plan, step, elapsed, &log)?;
            }
        }
        let seconds = started.elapsed().as_secs_f64();
        self.save(run, plan, step, elapsed, &log)?;
        Ok(Summary {
            steps: step,
            finished: step >= plan.steps,
            last,
            seconds: elapsed,
            per_second: ((step - first) as usize * plan.per_step) as f64 / seconds.max(1e-9),
        })
    }

    /// Checkpoints `run` after `step` steps, puts its newest files into the folder and redraws
    /// the loss plot.
    fn save<R: Run>(&self, run: &R, plan: &Plan, step: u64, elapsed: f64, log: &TrainLog<R::Row>) -> Result<()> {
        let files = run.state_files(&self.dir)?;
        let state = CheckpointState {
            step,
            elapsed,
            config: self.config.clone(),
        };
        let named: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (*n, b.as_slice())).collect();
        checkpoint::save(&self.dir, &state, &named)?;
        for (name, bytes) in named.into_iter().filter(|(n, _)| R::NEWEST.contains(n)) {
            write_atomic(&self.dir.join(name), bytes)?;
        }
        run.plot(log.rows()).save_png(&plan.plot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::train::log::{log_row, plot_rows};

    // The running sum, and its held-out "score" (the sum again).
    log_row! {
        pub struct SumRow (min_columns = 4) {
            step,
            seconds = "seconds",
            sum = "sum",
            held_out = "held_out",
        }
    }

    /// Adds its step number to a sum at each step; its "loss" is not finite at `nan_at`.
    struct Sum {
        sum: f64,
        nan_at: Option<u64>,
    }

    impl Run for Sum {
        type Row = SumRow;
        const NEWEST: &'static [&'static str] = &["sum.txt"];

        fn step(&mut self, step: u64) -> Result<SumRow> {
            self.sum += step as f64;
            let sum = if self.nan_at == Some(step) { f64::NAN } else { self.sum };
            Ok(SumRow {
                step: step + 1,
                seconds: 0.0,
                sum,
                held_out: f64::NAN,
            })
        }

        fn non_finite(&self, row: &SumRow) -> Option<String> {
            (!row.sum.is_finite()).then(|| format!("sum {}", row.sum))
        }

        fn held_out(&mut self, _step: u64, row: &mut SumRow) -> Result<()> {
            row.held_out = self.sum;
            Ok(())
        }

        fn message(&self, row: &SumRow) -> String {
            format!("sum {}", row.sum)
        }

        fn state_files(&self, _dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>> {
            Ok(vec![("sum.txt", self.sum.to_string().into_bytes())])
        }

        fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()> {
            let text = String::from_utf8(checkpoint.file("sum.txt", 64)?).unwrap();
            self.sum = text.parse().unwrap();
            Ok(())
        }

        fn plot(&self, rows: &[SumRow]) -> Picture {
            plot_rows(rows, &[("sum", [0.0; 3], &|r| r.sum)])
        }
    }

    fn plan(dir: &Path, pause_at: Option<u64>) -> Plan<'static> {
        Plan {
            stage: "sum",
            steps: 10,
            pause_at,
            checkpoint_every: 3,
            eval_every: 4,
            per_step: 1,
            log: dir.join("log.csv"),
            plot: dir.join("loss.png"),
        }
    }

    /// Claims `dir`, restores, and runs a fresh `Sum` through `plan`.
    fn run(dir: &Path, resume: bool, pause_at: Option<u64>, nan_at: Option<u64>) -> Result<(Summary<SumRow>, f64)> {
        let folder = RunFolder::claim(dir, serde_json::json!({"steps": 10, "seed": 1}), &["steps"], resume, false)?;
        let mut sum = Sum { sum: 0.0, nan_at };
        folder.restore(&mut sum)?;
        let summary = folder.train(&mut sum, &plan(dir, pause_at), &Silent)?;
        Ok((summary, sum.sum))
    }

    fn latest_step(dir: &Path) -> u64 {
        checkpoint::load(&checkpoint::latest(dir).unwrap().unwrap()).unwrap().state.step
    }

    #[test]
    fn a_paused_run_resumes_to_the_state_and_log_of_an_uninterrupted_one() {
        let tmp = tempfile::tempdir().unwrap();
        let (whole, cut) = (tmp.path().join("whole"), tmp.path().join("cut"));
        let (summary, sum) = run(&whole, false, None, None).unwrap();
        assert!(summary.finished && summary.steps == 10 && sum == 45.0, "{summary:?}");
        let (paused, _) = run(&cut, false, Some(5), None).unwrap();
        assert!(!paused.finished && paused.steps == 5);
        assert_eq!(latest_step(&cut), 5, "a pause checkpoints where it stops");
        let (resumed, sum) = run(&cut, true, None, None).unwrap();
        assert!(resumed.finished && sum == 45.0, "{resumed:?}");
        let numbers = |dir: &Path| {
            let log = TrainLog::<SumRow>::open(&dir.join("log.csv"), u64::MAX).unwrap();
            log.rows().iter().map(|r| (r.step, r.sum, r.held_out.to_bits())).collect::<Vec<_>>()
        };
        assert_eq!(numbers(&cut), numbers(&whole), "each step logged once, with the same numbers");
        // Held-out scores every 4 steps and at the last.
        let scored: Vec<u64> = numbers(&whole)
            .iter()
            .filter(|r| !f64::from_bits(r.2).is_nan())
            .map(|r| r.0)
            .collect();
        assert_eq!(scored, [4, 8, 10]);
        assert_eq!(
            std::fs::read_to_string(whole.join("sum.txt")).unwrap(),
            "45",
            "the newest state in the folder"
        );
        assert!(whole.join("loss.png").is_file());
    }

    #[test]
    fn a_step_whose_loss_is_not_finite_stops_naming_the_newest_checkpoint() {
        let tmp = tempfile::tempdir().unwrap();
        let err = run(tmp.path(), false, None, Some(7)).unwrap_err();
        let Error::Diverged { step, checkpoint, .. } = &err else {
            panic!("{err}")
        };
        assert_eq!(*step, 8);
        assert_eq!(checkpoint.as_deref(), checkpoint::latest(tmp.path()).unwrap().as_deref());
        assert_eq!(latest_step(tmp.path()), 6, "checkpointed after every 3 steps");
        // Diverging at once still leaves the untrained state to resume from.
        let at_once = tmp.path().join("at-once");
        assert!(matches!(run(&at_once, false, None, Some(0)), Err(Error::Diverged { .. })));
        assert_eq!(latest_step(&at_once), 0);
    }

    #[test]
    fn a_claim_holds_the_folder_and_a_rerun_and_a_changed_resume_are_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("run");
        run(&dir, false, Some(2), None).unwrap();
        let config = |seed: u64| serde_json::json!({"steps": 20, "seed": seed});
        // Another process is refused while it is held (tests/train.rs; src/folder_lock.rs).
        let held = RunFolder::claim(&dir, config(1), &["steps"], true, false).unwrap();
        assert!(dir.join(crate::folder_lock::LOCK_FILE).exists(), "the run holds its folder");
        drop(held);
        assert!(!dir.join(crate::folder_lock::LOCK_FILE).exists(), "and lets it go when done");
        assert!(matches!(
            RunFolder::claim(&dir, config(1), &["steps"], false, false),
            Err(Error::RunExists { step: 2, .. })
        ));
        let err = RunFolder::claim(&dir, config(2), &["steps"], true, false)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("seed") && err.contains("only steps may change"), "{err}");
        let missing = tmp.path().join("missing");
        assert!(matches!(
            RunFolder::claim(&missing, config(1), &["steps"], true, false),
            Err(Error::Resume { .. })
        ));
        assert!(!missing.exists(), "a refused resume leaves no folder behind");
    }
}

//! What a farm render is, written down before anything is submitted: the
//! iteration ranges of the shards, the folder layout and the two batch
//! scripts (a job array of shards and a dependent merge). Pure functions of
//! the options, so that `--dry-run` prints exactly what would run.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

/// Resources and placement of the batch jobs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Resources {
    /// `--partition`, if any.
    pub partition: Option<String>,
    /// `--time` (Slurm's syntax, e.g. `01:00:00`), if any.
    pub time: Option<String>,
    /// `--mem` (e.g. `4G`), if any.
    pub mem: Option<String>,
    /// CPUs per shard task (its render threads).
    pub cpus_per_task: u32,
}

/// A render split into iteration shards.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The scene file (absolute).
    pub scene: PathBuf,
    /// Iterations of the whole render.
    pub iterations: u64,
    /// Inclusive 1-based ranges, one per shard, tiling 1..=iterations.
    pub ranges: Vec<(u64, u64)>,
    /// Further `render-cli` flags (integrator, resolution, ...).
    pub render_flags: Vec<String>,
    /// The `render-cli` binary (absolute; on a shared file system).
    pub render_cli: PathBuf,
    /// The shared folder of scripts, shards, logs and the result.
    pub folder: PathBuf,
    /// Batch resources.
    pub resources: Resources,
    /// Seconds between the shards' checkpoints; `None`: render-cli's
    /// default (300 s).
    pub checkpoint_every: Option<f64>,
}

/// `iterations` split into `shards` contiguous ranges whose lengths differ
/// by at most one (the first ones longer).
pub fn shard_ranges(iterations: u64, shards: u64) -> Result<Vec<(u64, u64)>, String> {
    if shards == 0 || shards > iterations {
        return Err(format!(
            "--shards {shards}: expected 1 to {iterations} (the number of iterations)"
        ));
    }
    let (base, extra) = (iterations / shards, iterations % shards);
    let mut first = 1;
    Ok((0..shards)
        .map(|k| {
            let last = first + base - 1 + u64::from(k < extra);
            let range = (first, last);
            first = last + 1;
            range
        })
        .collect())
}

impl Plan {
    /// The partial film of shard `k`.
    pub fn shard_file(&self, k: usize) -> PathBuf {
        self.folder.join(format!("shard-{k}.rltfilm"))
    }

    /// The folder of the shards' checkpoints.
    pub fn checkpoint_folder(&self) -> PathBuf {
        self.folder.join("checkpoints")
    }

    /// The checkpoint of shard `k` while it renders (removed when its
    /// partial film is written; kept if the task is killed or cancelled,
    /// for the resubmitted task to resume).
    pub fn checkpoint_file(&self, k: usize) -> PathBuf {
        self.checkpoint_folder().join(format!("shard-{k}.rltfilm"))
    }

    /// The merged partial film (merge again with other renders' films).
    pub fn film_file(&self) -> PathBuf {
        self.folder.join("film.rltfilm")
    }

    /// The merged image.
    pub fn image_file(&self) -> PathBuf {
        self.folder.join("image.exr")
    }

    /// The batch script of the shard job array.
    pub fn shards_script_file(&self) -> PathBuf {
        self.folder.join("shards.sh")
    }

    /// The batch script of the merge job.
    pub fn merge_script_file(&self) -> PathBuf {
        self.folder.join("merge.sh")
    }

    /// Shards whose partial film is not (yet) in the folder. Films are
    /// written under a temporary name and renamed when complete, so a
    /// present file is a whole shard.
    pub fn missing_shards(&self) -> Vec<usize> {
        (0..self.ranges.len())
            .filter(|&k| !self.shard_file(k).is_file())
            .collect()
    }

    /// The job-array script: task k renders range k into `shard-k.rltfilm`,
    /// checkpointing into `checkpoints/shard-k.rltfilm`, which a
    /// resubmitted task resumes.
    pub fn shards_script(&self) -> String {
        // %a the task, %A the array job: a resubmitted shard keeps its first log.
        let mut s = self.script_header("rlt-shard", "shard-%a-job%A.out");
        let ranges: Vec<String> = self
            .ranges
            .iter()
            .map(|(a, b)| format!("{a}..{b}"))
            .collect();
        let _ = writeln!(s, "ranges=({})", ranges.join(" "));
        let _ = writeln!(s, "k=${{SLURM_ARRAY_TASK_ID:?submit as a job array}}");
        let mut command = vec![
            quote(&self.render_cli.display().to_string()),
            quote(&self.scene.display().to_string()),
            "--iteration-range".to_owned(),
            "\"${ranges[$k]}\"".to_owned(),
            "--partial".to_owned(),
            format!(
                "{}/shard-$k.rltfilm",
                quote(&self.folder.display().to_string())
            ),
            "--checkpoint".to_owned(),
            format!(
                "{}/shard-$k.rltfilm",
                quote(&self.checkpoint_folder().display().to_string())
            ),
            "--threads".to_owned(),
            "\"${SLURM_CPUS_PER_TASK:-1}\"".to_owned(),
        ];
        if let Some(seconds) = self.checkpoint_every {
            command.extend(["--checkpoint-every".to_owned(), seconds.to_string()]);
        }
        command.extend(self.render_flags.iter().map(|f| quote(f)));
        let _ = writeln!(s, "exec {}", command.join(" "));
        s
    }

    /// The merge script: every shard into `film.rltfilm`, then the image.
    pub fn merge_script(&self) -> String {
        let mut s = self.script_header("rlt-merge", "merge-job%j.out");
        let render = quote(&self.render_cli.display().to_string());
        let shards: Vec<String> = (0..self.ranges.len())
            .map(|k| quote(&self.shard_file(k).display().to_string()))
            .collect();
        let _ = writeln!(
            s,
            "{render} merge {} -o {}",
            shards.join(" "),
            quote(&self.film_file().display().to_string())
        );
        let _ = writeln!(
            s,
            "exec {render} merge {} -o {} --png {}",
            quote(&self.film_file().display().to_string()),
            quote(&self.image_file().display().to_string()),
            quote(&self.folder.join("image.png").display().to_string())
        );
        s
    }

    fn script_header(&self, name: &str, log: &str) -> String {
        let r = &self.resources;
        let mut s = String::from("#!/bin/bash\n");
        let _ = writeln!(
            s,
            "# Written by `cargo xtask farm` for {} ({} iterations in {} shards).",
            self.scene.display(),
            self.iterations,
            self.ranges.len()
        );
        let _ = writeln!(s, "#SBATCH --job-name={name}");
        let _ = writeln!(
            s,
            "#SBATCH --output={}",
            self.folder.join("logs").join(log).display()
        );
        let _ = writeln!(s, "#SBATCH --cpus-per-task={}", r.cpus_per_task);
        for (key, value) in [
            ("partition", &r.partition),
            ("time", &r.time),
            ("mem", &r.mem),
        ] {
            if let Some(v) = value {
                let _ = writeln!(s, "#SBATCH --{key}={v}");
            }
        }
        s.push_str("set -euo pipefail\n");
        s
    }

    /// The plan as `farm.json` keeps it (for `farm resume`).
    pub fn to_json(&self, array_job: Option<&str>, merge_job: Option<&str>) -> Value {
        let r = &self.resources;
        json!({
            "scene": self.scene.display().to_string(),
            "iterations": self.iterations,
            "ranges": self.ranges,
            "render_flags": self.render_flags,
            "render_cli": self.render_cli.display().to_string(),
            "folder": self.folder.display().to_string(),
            "partition": r.partition,
            "time": r.time,
            "mem": r.mem,
            "cpus_per_task": r.cpus_per_task,
            "checkpoint_every": self.checkpoint_every,
            "array_job": array_job,
            "merge_job": merge_job,
        })
    }

    /// The plan of a `farm.json`, and the ids of its last array job.
    pub fn from_json(v: &Value) -> Result<(Self, Option<String>), String> {
        let text = |key: &str| {
            v[key]
                .as_str()
                .map(str::to_owned)
                .ok_or_else(|| format!("farm.json: '{key}' missing or not a string"))
        };
        let optional = |key: &str| v[key].as_str().map(str::to_owned);
        let ranges = v["ranges"]
            .as_array()
            .ok_or("farm.json: 'ranges' missing")?
            .iter()
            .map(|r| match (r[0].as_u64(), r[1].as_u64()) {
                (Some(a), Some(b)) => Ok((a, b)),
                _ => Err("farm.json: a range is not [first, last]".to_owned()),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let render_flags = v["render_flags"]
            .as_array()
            .ok_or("farm.json: 'render_flags' missing")?
            .iter()
            .map(|f| {
                f.as_str()
                    .map(str::to_owned)
                    .ok_or("farm.json: a flag is not a string")
            })
            .collect::<Result<Vec<_>, _>>()?;
        let plan = Self {
            scene: PathBuf::from(text("scene")?),
            iterations: v["iterations"]
                .as_u64()
                .ok_or("farm.json: 'iterations' missing")?,
            ranges,
            render_flags,
            render_cli: PathBuf::from(text("render_cli")?),
            folder: PathBuf::from(text("folder")?),
            resources: Resources {
                partition: optional("partition"),
                time: optional("time"),
                mem: optional("mem"),
                cpus_per_task: v["cpus_per_task"].as_u64().unwrap_or(1) as u32,
            },
            checkpoint_every: v["checkpoint_every"].as_f64(),
        };
        Ok((plan, optional("array_job")))
    }
}

/// `s` as one single-quoted shell word.
pub fn quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        return s.to_owned();
    }
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The folder a plan writes into by default: `target/farm/<scene name>`.
pub fn default_folder(root: &Path, scene: &Path) -> PathBuf {
    let name = if scene.file_name().is_some_and(|n| n == "scene.toml") {
        scene.parent().and_then(Path::file_name)
    } else {
        scene.file_stem()
    };
    root.join("target/farm").join(
        name.map_or("render".into(), |n| n.to_string_lossy())
            .as_ref(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> Plan {
        Plan {
            scene: PathBuf::from("/w/scenes/cornell-box/scene.toml"),
            iterations: 10,
            ranges: shard_ranges(10, 3).unwrap(),
            render_flags: vec![
                "--integrator".into(),
                "vcm".into(),
                "--seed".into(),
                "it's".into(),
            ],
            render_cli: PathBuf::from("/w/target/release/render-cli"),
            folder: PathBuf::from("/shared/farm dir"),
            resources: Resources {
                partition: Some("local".into()),
                time: Some("00:10:00".into()),
                mem: None,
                cpus_per_task: 2,
            },
            checkpoint_every: Some(60.0),
        }
    }

    #[test]
    fn ranges_tile_the_render_evenly() {
        assert_eq!(shard_ranges(10, 3).unwrap(), vec![(1, 4), (5, 7), (8, 10)]);
        assert_eq!(
            shard_ranges(4, 4).unwrap(),
            vec![(1, 1), (2, 2), (3, 3), (4, 4)]
        );
        assert_eq!(shard_ranges(7, 1).unwrap(), vec![(1, 7)]);
        assert!(shard_ranges(3, 4).is_err() && shard_ranges(3, 0).is_err());
    }

    #[test]
    fn scripts_render_each_range_and_merge_every_shard() {
        let p = plan();
        let shards = p.shards_script();
        assert!(shards.contains("ranges=(1..4 5..7 8..10)"), "{shards}");
        assert!(shards.contains("#SBATCH --partition=local"), "{shards}");
        assert!(shards.contains("#SBATCH --time=00:10:00"), "{shards}");
        assert!(!shards.contains("--mem"), "{shards}");
        assert!(
            shards.contains("--partial '/shared/farm dir'/shard-$k.rltfilm"),
            "{shards}"
        );
        assert!(shards.contains(r"--seed 'it'\''s'"), "{shards}");
        assert!(
            shards.contains(
                "--checkpoint '/shared/farm dir/checkpoints'/shard-$k.rltfilm --threads \"${SLURM_CPUS_PER_TASK:-1}\" --checkpoint-every 60 "
            ),
            "{shards}"
        );
        let merge = p.merge_script();
        assert!(
            merge.contains("'/shared/farm dir/shard-2.rltfilm' -o '/shared/farm dir/film.rltfilm'"),
            "{merge}"
        );
        assert!(
            merge.contains(
                "exec /w/target/release/render-cli merge '/shared/farm dir/film.rltfilm' -o"
            ),
            "{merge}"
        );
    }

    #[test]
    fn plans_survive_farm_json() {
        let p = plan();
        let (q, job) = Plan::from_json(&p.to_json(Some("17"), Some("18"))).unwrap();
        assert_eq!((q, job.as_deref()), (p, Some("17")));
    }

    #[test]
    fn default_folders_are_named_after_the_scene() {
        let root = Path::new("/w");
        assert_eq!(
            default_folder(root, Path::new("scenes/cornell-box/scene.toml")),
            PathBuf::from("/w/target/farm/cornell-box")
        );
        assert_eq!(
            default_folder(root, Path::new("x/model.glb")),
            PathBuf::from("/w/target/farm/model")
        );
    }
}

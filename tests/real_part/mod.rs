//! The one rule for tests that need a real part outside the crate (a
//! container engine, a PostgreSQL server, Chromium, a Python tool):
//!
//! - under CI (`CI=true`, as `.ci/run` and hosted CI set it) a missing part
//!   fails the test, with a message naming the part and how to install it;
//! - outside CI a developer without the part may skip, and the skip is
//!   written to stderr past the harness's capture;
//! - a per-suite override variable (`ISOREMESH_CONTAINER_TEST=skip|require`,
//!   for example) forces either behaviour.
//!
//! Every suite that gets its part records how it ended (ran and its seconds,
//! skipped and why, or failed) under `CARGO_TARGET_TMPDIR/real-parts/`, so
//! that `.ci/run` can print one summary line per suite.

#![allow(dead_code)]

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// What to do when a part is missing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Policy {
    /// Fail the test: CI, or the override says `require`.
    Require,
    /// Skip with a message on stderr: a developer's machine.
    MaySkip,
    /// Skip without probing: the override says `skip` (never under CI).
    ForceSkip,
}

/// The policy for a suite from the `CI` variable and the suite's override
/// variable's value. `CI` counts when it is `true` or `1`, as hosted CI
/// services set it. An explicit `skip` under CI is refused: CI must never
/// skip what it claims to test.
pub fn policy_from(ci: Option<&str>, override_value: Option<&str>) -> Policy {
    let ci = matches!(
        ci.map(str::trim),
        Some("true") | Some("1") | Some("TRUE") | Some("True")
    );
    match override_value.map(str::trim) {
        Some("require") => Policy::Require,
        Some("skip") if !ci => Policy::ForceSkip,
        _ if ci => Policy::Require,
        _ => Policy::MaySkip,
    }
}

/// The policy for a suite from the process environment.
pub fn policy(override_var: &str) -> Policy {
    policy_from(
        std::env::var("CI").ok().as_deref(),
        std::env::var(override_var).ok().as_deref(),
    )
}

/// A part a suite needs: its name, the override variable, and the one line
/// that tells a reader how to install it.
#[derive(Clone, Copy, Debug)]
pub struct Part {
    /// The suite's name in the CI summary, e.g. `container`.
    pub suite: &'static str,
    /// What is needed, e.g. `a container engine (docker or podman)`.
    pub what: &'static str,
    /// The override variable, e.g. `ISOREMESH_CONTAINER_TEST`.
    pub override_var: &'static str,
    /// How to install it, e.g. `run .ci/install-container-tools.sh as root`.
    pub install: &'static str,
}

/// A suite that has its part and is running; records its outcome on drop.
#[derive(Debug)]
pub struct Run {
    suite: &'static str,
    started: Instant,
}

impl Part {
    /// Probes for the part with `probe` (which returns the handle to it, or
    /// why it is missing) and applies the policy: `Some` when the suite
    /// should run, `None` when it skips (after saying so), and a panic when
    /// a required part is missing.
    pub fn acquire<T>(&self, probe: impl FnOnce() -> Result<T, String>) -> Option<(T, Run)> {
        self.acquire_with(policy(self.override_var), probe)
    }

    /// `acquire` under an explicit policy (for tests of the rule itself).
    pub fn acquire_with<T>(
        &self,
        policy: Policy,
        probe: impl FnOnce() -> Result<T, String>,
    ) -> Option<(T, Run)> {
        if policy == Policy::ForceSkip {
            self.skip(&format!("{}=skip", self.override_var));
            return None;
        }
        match probe() {
            Ok(handle) => Some((
                handle,
                Run {
                    suite: self.suite,
                    started: Instant::now(),
                },
            )),
            Err(reason) => {
                if policy == Policy::Require {
                    record(self.suite, &format!("failed: missing {}", self.what));
                    panic!(
                        "{} suite: {} is missing ({}). Install it: {}. \
                         (Required because {}; outside CI the suite may skip.)",
                        self.suite,
                        self.what,
                        reason,
                        self.install,
                        if std::env::var(self.override_var).as_deref() == Ok("require") {
                            format!("{}=require", self.override_var)
                        } else {
                            "CI=true".to_string()
                        }
                    );
                }
                self.skip(&reason);
                None
            }
        }
    }

    fn skip(&self, reason: &str) {
        let _ = writeln!(
            std::io::stderr(),
            "{} suite: SKIPPED: {} ({}). Install: {}",
            self.suite,
            self.what,
            reason,
            self.install
        );
        record(self.suite, &format!("skipped: {reason}"));
    }
}

impl Run {
    /// Seconds since the part was acquired.
    pub fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        let secs = self.seconds();
        if std::thread::panicking() {
            record(self.suite, &format!("failed after {secs:.1} s"));
        } else {
            record(self.suite, &format!("ran in {secs:.1} s"));
        }
    }
}

/// Where suite outcomes are written: one file per suite, appended per test.
pub fn record_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("real-parts")
}

fn record(suite: &str, line: &str) {
    let dir = record_dir();
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    if let Ok(mut f) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(suite))
    {
        let _ = writeln!(f, "{line}");
    }
}

/// Probes a command: `Ok` with its stdout when it runs and exits 0, else
/// the reason (not found, or the exit status and the first stderr line).
pub fn probe_command(program: &str, args: &[&str]) -> Result<String, String> {
    match std::process::Command::new(program).args(args).output() {
        Err(e) => Err(format!("`{program}` cannot be started: {e}")),
        Ok(out) if out.status.success() => Ok(String::from_utf8_lossy(&out.stdout).into_owned()),
        Ok(out) => Err(format!(
            "`{program} {}` exited with {}: {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .next()
                .unwrap_or("")
        )),
    }
}

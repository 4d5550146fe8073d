//! The real-part rule itself (`tests/real_part`): under CI a missing part
//! fails the test and says how to install it; outside CI it skips and says
//! so; the per-suite override forces either way, except that CI never
//! skips on request.

mod real_part;

use real_part::{policy_from, probe_command, Part, Policy};

const MISSING_ENGINE: Part = Part {
    suite: "rule-self-test",
    what: "a container engine at /nonexistent/podman",
    override_var: "ISOREMESH_RULE_SELF_TEST",
    install: "nothing to install: this part is missing on purpose",
};

fn missing_engine() -> Result<String, String> {
    probe_command("/nonexistent/podman", &["info"])
}

#[test]
fn policy_follows_ci_and_the_override() {
    assert_eq!(policy_from(None, None), Policy::MaySkip);
    assert_eq!(policy_from(Some("false"), None), Policy::MaySkip);
    assert_eq!(policy_from(Some("true"), None), Policy::Require);
    assert_eq!(policy_from(Some("1"), None), Policy::Require);
    assert_eq!(policy_from(None, Some("require")), Policy::Require);
    assert_eq!(policy_from(None, Some("skip")), Policy::ForceSkip);
    // CI never skips what it claims to test, even when asked to.
    assert_eq!(policy_from(Some("true"), Some("skip")), Policy::Require);
    assert_eq!(policy_from(Some("true"), Some("require")), Policy::Require);
}

#[test]
fn a_missing_part_fails_under_ci_with_the_install_hint() {
    let policy = policy_from(Some("true"), None);
    let result = std::panic::catch_unwind(|| MISSING_ENGINE.acquire_with(policy, missing_engine));
    let err = result.expect_err("a missing part under CI must fail the test");
    let msg = err.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(msg.contains("/nonexistent/podman"), "{msg}");
    assert!(msg.contains("missing"), "{msg}");
    assert!(msg.contains("Install it"), "{msg}");
}

#[test]
fn a_missing_part_skips_outside_ci() {
    let policy = policy_from(None, None);
    assert!(MISSING_ENGINE
        .acquire_with(policy, missing_engine)
        .is_none());
}

#[test]
fn a_present_part_runs_and_hands_over_the_probe_result() {
    let (out, run) = MISSING_ENGINE
        .acquire_with(Policy::Require, || {
            probe_command("sh", &["-c", "echo here"])
        })
        .expect("sh is present");
    assert_eq!(out.trim(), "here");
    assert!(run.seconds() >= 0.0);
}

#[test]
fn a_forced_skip_does_not_probe() {
    let probed = std::cell::Cell::new(false);
    let got = MISSING_ENGINE.acquire_with(Policy::ForceSkip, || {
        probed.set(true);
        Ok(())
    });
    assert!(got.is_none());
    assert!(!probed.get());
}

//! The container image as a platform runs it (issue 7): build
//! `docker/Dockerfile`, start the image, submit a remeshing job over HTTP,
//! poll it, download and parse the result, then send SIGTERM and require a
//! clean exit (status 0) before `docker stop` would escalate to SIGKILL.
//!
//! The engine is docker where one answers `docker info`, otherwise rootful
//! podman with the runc runtime and host networking. Where no registry can
//! be reached, podman builds against local stand-ins for the public base
//! images: `localhost/debian:bookworm-slim` made by
//! `.ci/install-container-tools.sh` (debootstrap) and a builder image made
//! here from it with this machine's Rust toolchain and CA bundle copied in.
//! The Dockerfile itself is the one users get; only its `BUILDER_IMAGE` /
//! `RUNTIME_IMAGE` build arguments change.
//!
//! A missing engine (or a base image that cannot be had) follows the
//! real-part rule of `tests/real_part`: under CI it fails the test, naming
//! what is missing and how to install it; elsewhere it skips and says so.
//! `ISOREMESH_CONTAINER_TEST=skip` skips on purpose outside CI; `=require`
//! turns any skip into a failure. `ISOREMESH_TEST_BUILDER_IMAGE` /
//! `ISOREMESH_TEST_RUNTIME_IMAGE` override the base images.

mod real_part;

use std::io::Write;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::thread::sleep;
use std::time::{Duration, Instant};

use isoremesh::io::{Format, ReadOptions};
use reqwest::blocking::{multipart, Client};
use reqwest::StatusCode;

/// The local stand-in for `debian:bookworm-slim` that the CI install script
/// creates with debootstrap.
const LOCAL_DEBIAN: &str = "localhost/debian:bookworm-slim";
/// The image under test (rebuilt on every run; its layers are the cache).
const IMAGE_TAG: &str = "localhost/isoremesh:container-test";
/// The image's shutdown grace (ISOREMESH_SHUTDOWN_GRACE_SECS in the
/// Dockerfile) is 8 s so that it ends before `docker stop`'s default 10 s;
/// that 10 s is the deadline for a clean exit after SIGTERM.
const STOP_DEADLINE: Duration = Duration::from_secs(10);
const READY_DEADLINE: Duration = Duration::from_secs(60);
const JOB_DEADLINE: Duration = Duration::from_secs(180);

/// A builder image for podman without registry access: the local Debian, a C
/// linker, CA certificates, and the host's Rust toolchain (bin/ and lib/ of
/// its sysroot, mounted at /toolchain during the build). The host's CA
/// bundle replaces the image's when mounted, so that cargo can reach
/// crates.io through the same TLS-inspecting proxies the host trusts.
const BUILDER_CONTAINERFILE: &str = r#"ARG BASE_IMAGE
FROM ${BASE_IMAGE}
RUN apt-get update -q \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        gcc libc6-dev ca-certificates \
 && rm -rf /var/lib/apt/lists/*
RUN mkdir -p /usr/local/rust /usr/local/cargo \
 && cp -a /toolchain/bin /toolchain/lib /usr/local/rust/ \
 && if [ -f /host-ca.crt ]; then cp /host-ca.crt /etc/ssl/certs/ca-certificates.crt; fi
ENV CARGO_HOME=/usr/local/cargo \
    PATH=/usr/local/cargo/bin:/usr/local/rust/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
RUN cargo --version && rustc --version
"#;

/// Writes past the harness's output capture, so that skips and measurements
/// show in CI logs of passing runs too.
fn note(msg: &str) {
    let _ = writeln!(std::io::stderr(), "container test: {msg}");
}

/// The part this suite needs, under the real-part rule.
const CONTAINER_ENGINE: real_part::Part = real_part::Part {
    suite: "container",
    what: "a container engine (docker, or rootful podman with runc) and its base images",
    override_var: "ISOREMESH_CONTAINER_TEST",
    install:
        "run .ci/install-container-tools.sh as root (podman, runc, and a debootstrapped base image)",
};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Docker,
    Podman,
}

#[derive(Clone, Copy, Debug)]
struct Engine {
    kind: Kind,
}

impl Engine {
    /// Docker if an engine answers, else podman if it can run containers
    /// (rootful, runc); the error lists why neither can.
    fn detect() -> Result<Engine, String> {
        let docker = Engine { kind: Kind::Docker };
        let podman = Engine { kind: Kind::Podman };
        let docker_err = match docker.run(&["info"]) {
            Ok(_) => return Ok(docker),
            Err(e) => e,
        };
        let podman_err = match podman.run(&["info"]) {
            Ok(_) => return Ok(podman),
            Err(e) => e,
        };
        Err(format!(
            "no container engine: `docker info` failed ({}); `podman --runtime runc info` failed ({}). \
             Run .ci/install-container-tools.sh as root to install podman",
            first_line(&docker_err),
            first_line(&podman_err)
        ))
    }

    fn command(self) -> Command {
        match self.kind {
            Kind::Docker => Command::new("docker"),
            Kind::Podman => {
                let mut c = Command::new("podman");
                // crun, podman's default, fails on the CI machines; runc works.
                c.args(["--runtime", "runc"]);
                c
            }
        }
    }

    fn output(self, args: &[&str]) -> Result<Output, String> {
        self.command()
            .args(args)
            .output()
            .map_err(|e| format!("cannot start {:?}: {e}", self.kind))
    }

    /// Runs the engine; trimmed stdout on success, else stderr.
    fn run(self, args: &[&str]) -> Result<String, String> {
        let out = self.output(args)?;
        if out.status.success() {
            Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
        } else {
            Err(format!(
                "{:?} {} exited with {}: {}{}",
                self.kind,
                args.first().copied().unwrap_or(""),
                out.status,
                String::from_utf8_lossy(&out.stderr).trim(),
                String::from_utf8_lossy(&out.stdout).trim()
            ))
        }
    }

    fn image_exists(self, image: &str) -> bool {
        match self.kind {
            Kind::Podman => self.run(&["image", "exists", image]).is_ok(),
            Kind::Docker => self.run(&["image", "inspect", image]).is_ok(),
        }
    }

    /// Runs a build, failing the test with the end of its log.
    fn build(self, args: &[String], what: &str) {
        let started = Instant::now();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = self.output(&args).unwrap_or_else(|e| panic!("{what}: {e}"));
        if !out.status.success() {
            let log = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            let tail: Vec<&str> = log.lines().rev().take(80).collect();
            let tail: Vec<&str> = tail.into_iter().rev().collect();
            panic!(
                "{what} failed ({}) after {:.0?}; last lines:\n{}",
                out.status,
                started.elapsed(),
                tail.join("\n")
            );
        }
        note(&format!("{what}: {:.1} s", started.elapsed().as_secs_f64()));
    }
}

fn first_line(s: &str) -> &str {
    s.lines().find(|l| !l.trim().is_empty()).unwrap_or(s)
}

/// Base images for the build: `None` keeps the Dockerfile's public default.
struct Bases {
    builder: Option<String>,
    runtime: Option<String>,
}

/// Chooses the base images; `Err` is a reason to skip.
fn choose_bases(engine: Engine) -> Result<Bases, String> {
    let mut bases = Bases {
        builder: std::env::var("ISOREMESH_TEST_BUILDER_IMAGE").ok(),
        runtime: std::env::var("ISOREMESH_TEST_RUNTIME_IMAGE").ok(),
    };
    if engine.kind == Kind::Docker || (bases.builder.is_some() && bases.runtime.is_some()) {
        return Ok(bases);
    }
    if engine.image_exists(LOCAL_DEBIAN) {
        if bases.runtime.is_none() {
            bases.runtime = Some(LOCAL_DEBIAN.to_string());
        }
        if bases.builder.is_none() {
            bases.builder = Some(local_builder(engine));
        }
        return Ok(bases);
    }
    // No local stand-in: podman must pull the public images, which it can
    // only where a registry is reachable.
    engine
        .run(&["pull", "-q", "docker.io/library/debian:bookworm-slim"])
        .map(|_| bases)
        .map_err(|e| {
            format!(
                "podman runs but has no base image: {LOCAL_DEBIAN} is missing and the public \
                 one cannot be pulled ({}). Run .ci/install-container-tools.sh as root",
                first_line(&e)
            )
        })
}

/// Makes (once per toolchain version) the builder image with the host's
/// Rust toolchain and returns its tag.
fn local_builder(engine: Engine) -> String {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".to_string());
    let run = |args: &[&str]| -> String {
        let out = Command::new(&rustc)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run {rustc}: {e}"));
        assert!(out.status.success(), "{rustc} {args:?} failed");
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    };
    let sysroot = PathBuf::from(run(&["--print", "sysroot"]));
    let version = run(&["--version"]);
    // "rustc 1.95.0 (59807616e 2026-04-14)" -> "1.95.0"
    let number = version.split_whitespace().nth(1).unwrap_or("unknown");
    if !number.starts_with("1.95") {
        note(&format!(
            "NOTE: the host toolchain is {number}; the Dockerfile's default builder is Rust 1.95"
        ));
    }
    let tag = format!("localhost/isoremesh-builder:{number}");
    if engine.image_exists(&tag) {
        return tag;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("Containerfile");
    std::fs::write(&file, BUILDER_CONTAINERFILE).expect("write Containerfile");
    let mut args: Vec<String> = vec![
        "build".into(),
        "--network=host".into(),
        "--build-arg".into(),
        format!("BASE_IMAGE={LOCAL_DEBIAN}"),
        "-v".into(),
        format!("{}:/toolchain:ro", sysroot.display()),
    ];
    let ca = std::env::var("SSL_CERT_FILE")
        .map(PathBuf::from)
        .ok()
        .filter(|p| p.is_file())
        .or_else(|| Some(PathBuf::from("/etc/ssl/certs/ca-certificates.crt")))
        .filter(|p| p.is_file());
    if let Some(ca) = ca {
        args.push("-v".into());
        args.push(format!("{}:/host-ca.crt:ro", ca.display()));
    }
    args.extend([
        "-t".into(),
        tag.clone(),
        "-f".into(),
        file.display().to_string(),
        dir.path().display().to_string(),
    ]);
    engine.build(&args, &format!("builder image {tag}"));
    tag
}

/// Removes the container and its anonymous /data volume however the test
/// ends.
struct Container {
    engine: Engine,
    name: String,
}

impl Drop for Container {
    fn drop(&mut self) {
        let _ = self.engine.run(&["rm", "-f", "-v", &self.name]);
    }
}

impl Container {
    fn inspect(&self, format: &str) -> Result<String, String> {
        self.engine.run(&[
            "inspect",
            "--type",
            "container",
            "--format",
            format,
            &self.name,
        ])
    }

    fn logs(&self) -> String {
        match self.engine.output(&["logs", &self.name]) {
            Ok(o) => format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
            Err(e) => e,
        }
    }

    fn running(&self) -> bool {
        self.inspect("{{.State.Running}}").as_deref() == Ok("true")
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free loopback port")
}

fn repo_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn image_builds_serves_a_job_and_stops_cleanly_on_sigterm() {
    let Some(((engine, bases), _run)) = CONTAINER_ENGINE.acquire(|| {
        let engine = Engine::detect()?;
        let bases = choose_bases(engine)?;
        Ok((engine, bases))
    }) else {
        return;
    };
    let total = Instant::now();
    note(&format!(
        "engine {:?}; builder {}; runtime {}",
        engine.kind,
        bases.builder.as_deref().unwrap_or("(Dockerfile default)"),
        bases.runtime.as_deref().unwrap_or("(Dockerfile default)")
    ));

    // ---- build -----------------------------------------------------------
    let root = repo_root();
    let mut args: Vec<String> = vec!["build".into()];
    if engine.kind == Kind::Podman {
        // OCI images drop HEALTHCHECK; the docker format keeps it. Podman
        // builds here reach crates.io only through the host's network.
        args.extend(["--format".into(), "docker".into(), "--network=host".into()]);
    }
    for (name, value) in [
        ("BUILDER_IMAGE", &bases.builder),
        ("RUNTIME_IMAGE", &bases.runtime),
    ] {
        if let Some(v) = value {
            args.push("--build-arg".into());
            args.push(format!("{name}={v}"));
        }
    }
    args.extend([
        "-t".into(),
        IMAGE_TAG.into(),
        "-f".into(),
        root.join("docker/Dockerfile").display().to_string(),
        root.display().to_string(),
    ]);
    engine.build(&args, "image build");

    let size: u64 = engine
        .run(&["image", "inspect", "--format", "{{.Size}}", IMAGE_TAG])
        .expect("inspect image")
        .parse()
        .expect("image size is a number");
    note(&format!(
        "image size {:.1} MB ({size} bytes)",
        size as f64 / 1e6
    ));
    let user = engine
        .run(&[
            "image",
            "inspect",
            "--format",
            "{{.Config.User}}",
            IMAGE_TAG,
        ])
        .expect("inspect image user");
    assert!(
        !user.is_empty() && !user.starts_with("root") && !user.starts_with("0"),
        "the image must run as a non-root user, has USER {user:?}"
    );

    // ---- run -------------------------------------------------------------
    let port = free_port();
    let container = Container {
        engine,
        name: format!("isoremesh-container-test-{}", std::process::id()),
    };
    let _ = engine.run(&["rm", "-f", "-v", &container.name]);
    let mut run: Vec<String> = vec![
        "run".into(),
        "-d".into(),
        "--name".into(),
        container.name.clone(),
    ];
    match engine.kind {
        // Rootful podman's bridge does not work on the CI machines; on the
        // host network the server must listen on the chosen port itself.
        Kind::Podman => run.extend([
            "--network=host".into(),
            "-e".into(),
            format!("ISOREMESH_LISTEN=127.0.0.1:{port}"),
        ]),
        // Docker keeps the image's default listen address and maps the port.
        Kind::Docker => run.extend(["-p".into(), format!("127.0.0.1:{port}:8080")]),
    }
    // The hardening compose.yaml applies, so that the image is known to work
    // under it: read-only root, no capabilities, a memory limit.
    run.extend(
        [
            "-e",
            "ISOREMESH_WORKERS=1",
            "--read-only",
            "--tmpfs",
            "/tmp",
            "--cap-drop",
            "ALL",
            "--security-opt",
            "no-new-privileges",
            "--memory",
            "1g",
            IMAGE_TAG,
        ]
        .map(String::from),
    );
    let run: Vec<&str> = run.iter().map(String::as_str).collect();
    let started = Instant::now();
    engine.run(&run).expect("start the container");

    let base = format!("http://127.0.0.1:{port}");
    let client = Client::builder()
        .timeout(Duration::from_secs(10))
        .build()
        .expect("http client");
    loop {
        let ready = client
            .get(format!("{base}/readyz"))
            .timeout(Duration::from_secs(1))
            .send()
            .is_ok_and(|r| r.status() == StatusCode::OK);
        if ready {
            break;
        }
        if !container.running() || started.elapsed() > READY_DEADLINE {
            panic!(
                "no /readyz 200 within {:.1} s (running: {}); logs:\n{}",
                started.elapsed().as_secs_f64(),
                container.running(),
                container.logs()
            );
        }
        sleep(Duration::from_millis(20));
    }
    let cold_start = started.elapsed();
    note(&format!(
        "cold start (run command to first /readyz 200): {:.0} ms",
        cold_start.as_secs_f64() * 1e3
    ));

    // PID 1 is the server itself, as the non-root user: SIGTERM goes to it.
    let status = engine
        .run(&["exec", &container.name, "cat", "/proc/1/status"])
        .expect("read PID 1's status");
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .map(|v| v.split_whitespace().next().unwrap_or("").to_string())
            .unwrap_or_default()
    };
    assert_eq!(field("Name:"), "isoremesh", "PID 1 is not the server");
    assert_ne!(field("Uid:"), "0", "the server runs as root");

    // The image's HEALTHCHECK command succeeds against the live server.
    let health: serde_json::Value = serde_json::from_str(
        &engine
            .run(&[
                "image",
                "inspect",
                "--format",
                "{{json .Config.Healthcheck}}",
                IMAGE_TAG,
            ])
            .expect("inspect healthcheck"),
    )
    .expect("healthcheck is JSON");
    let test: Vec<String> = health["Test"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(
        test.first().map(String::as_str),
        Some("CMD"),
        "the image needs an exec-form HEALTHCHECK, has {health}"
    );
    let mut exec: Vec<&str> = vec!["exec", &container.name];
    exec.extend(test[1..].iter().map(String::as_str));
    engine
        .run(&exec)
        .unwrap_or_else(|e| panic!("HEALTHCHECK fails on a healthy server: {e}"));

    // ---- a job over HTTP -------------------------------------------------
    let obj = std::fs::read(root.join("tests/data/cube.obj")).expect("tests/data/cube.obj");
    let form = multipart::Form::new()
        .part(
            "mesh",
            multipart::Part::bytes(obj)
                .file_name("cube.obj")
                .mime_str("model/obj")
                .expect("mime"),
        )
        .part(
            "params",
            multipart::Part::text(r#"{"iterations": 2, "target_edge_ratio": 0.05}"#)
                .mime_str("application/json")
                .expect("mime"),
        );
    let job_started = Instant::now();
    let resp = client
        .post(format!("{base}/v1/jobs"))
        .multipart(form)
        .send()
        .expect("POST /v1/jobs");
    let status = resp.status();
    let location = resp
        .headers()
        .get("location")
        .and_then(|v| v.to_str().ok())
        .map(String::from);
    let body = resp.text().unwrap_or_default();
    assert_eq!(status, StatusCode::ACCEPTED, "submit: {body}");
    let location = location.expect("202 carries Location");
    let job_url = if location.starts_with("http") {
        location
    } else {
        format!("{base}{location}")
    };

    let final_status = loop {
        let job: serde_json::Value = client
            .get(&job_url)
            .send()
            .and_then(|r| r.error_for_status())
            .and_then(|r| r.json())
            .unwrap_or_else(|e| panic!("GET {job_url}: {e}"));
        let s = job["status"].as_str().unwrap_or("").to_string();
        if matches!(s.as_str(), "succeeded" | "failed" | "cancelled") {
            break (s, job);
        }
        assert!(
            job_started.elapsed() < JOB_DEADLINE,
            "job still {s} after {JOB_DEADLINE:?}: {job}"
        );
        sleep(Duration::from_millis(100));
    };
    assert_eq!(final_status.0, "succeeded", "job: {}", final_status.1);

    let resp = client
        .get(format!("{job_url}/result"))
        .send()
        .expect("GET result");
    assert_eq!(resp.status(), StatusCode::OK, "result status");
    let mime = resp
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .and_then(Format::from_mime);
    let bytes = resp.bytes().expect("result body");
    let format = mime
        .or_else(|| Format::from_magic(&bytes))
        .expect("result format from Content-Type or content");
    let mesh = isoremesh::io::read(&bytes, format, &ReadOptions::default())
        .expect("the result parses")
        .mesh;
    // The 12-triangle cube comes back refined to thousands of triangles.
    assert!(
        mesh.triangles.len() > 100,
        "result has only {} triangles",
        mesh.triangles.len()
    );
    note(&format!(
        "job: {} triangles in {:.0} ms (submit to result)",
        mesh.triangles.len(),
        job_started.elapsed().as_secs_f64() * 1e3
    ));

    // ---- SIGTERM ---------------------------------------------------------
    let signal: &[&str] = match engine.kind {
        Kind::Podman => &["kill", "--signal", "TERM"],
        Kind::Docker => &["kill", "-s", "TERM"],
    };
    let mut kill = signal.to_vec();
    kill.push(&container.name);
    let stopping = Instant::now();
    engine.run(&kill).expect("send SIGTERM");
    while container.running() {
        assert!(
            stopping.elapsed() < STOP_DEADLINE,
            "still running {STOP_DEADLINE:?} after SIGTERM; logs:\n{}",
            container.logs()
        );
        sleep(Duration::from_millis(20));
    }
    let stop_time = stopping.elapsed();
    let code = container.inspect("{{.State.ExitCode}}").expect("exit code");
    let logs = container.logs();
    assert_eq!(code, "0", "exit status after SIGTERM; logs:\n{logs}");
    note(&format!(
        "stopped {:.0} ms after SIGTERM, exit 0",
        stop_time.as_secs_f64() * 1e3
    ));

    // ISOREMESH_LOG_JSON=true is the image's default: every log line is JSON.
    let lines: Vec<&str> = logs.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(!lines.is_empty(), "the server logged nothing");
    for line in &lines {
        assert!(
            serde_json::from_str::<serde_json::Value>(line).is_ok(),
            "log line is not JSON: {line}"
        );
    }
    note(&format!(
        "total (build, run, job, stop): {:.1} s",
        total.elapsed().as_secs_f64()
    ));
}

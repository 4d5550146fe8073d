//! The `isoremesh` binary: a thin shell over the library. It parses
//! arguments, reads and writes files, shows progress, and prints every
//! failure as one line naming the file and the problem.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use std::collections::HashMap;

use isoremesh::io::companions::{companion_names, is_plain_relative, Companion};
use isoremesh::io::{Format, ReadOptions};
use isoremesh::params::Params;
use isoremesh::pipeline::{self, JobError};
use isoremesh::remesh::{Observer, Progress, Sizing, DEFAULT_MAX_OUTPUT_FACES};
use isoremesh::stats::{self, StatsOptions};

#[derive(Parser)]
#[command(
    name = "isoremesh",
    version,
    about = "Isotropic remeshing: CLI and HTTP service"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print quality statistics of a mesh.
    Stats(StatsArgs),
    /// Remesh a file toward a target edge length.
    Remesh(Box<RemeshArgs>),
    /// Run the HTTP service (see the README's "Service" section).
    #[cfg(feature = "service")]
    Serve(Box<isoremesh::service::ServiceConfig>),
    /// Manage the service's API keys.
    #[cfg(feature = "service")]
    #[command(subcommand)]
    Keys(KeysCommand),
}

#[cfg(feature = "service")]
#[derive(Subcommand)]
enum KeysCommand {
    /// Create a key named NAME: its hash is appended to FILE (created,
    /// private to its owner, when missing) and the key is printed once.
    New(NewKeyArgs),
}

#[cfg(feature = "service")]
#[derive(Args)]
struct NewKeyArgs {
    /// The key's unique name; its jobs belong to it.
    name: String,
    /// The key file that `serve --api-keys` reads.
    #[arg(long)]
    file: PathBuf,
    /// Jobs queued and running at once (default 16).
    #[arg(long)]
    max_active_jobs: Option<u32>,
    /// Sustained requests per second (default 20).
    #[arg(long)]
    requests_per_second: Option<f64>,
    /// Requests at once after idling (default 40).
    #[arg(long)]
    burst: Option<u32>,
    /// Bytes of uploads and results kept at once (default 8 GiB).
    #[arg(long)]
    max_stored_bytes: Option<u64>,
}

#[derive(Args)]
struct StatsArgs {
    /// The mesh file (OBJ, glTF, GLB, STL, PLY, OFF).
    input: PathBuf,
    /// Target edge length L for the band and histogram (default: mean edge length).
    #[arg(long)]
    target_edge_length: Option<f64>,
    /// Measure the distance to this reference mesh.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Area samples per side for the distance (vertices are added).
    #[arg(long, default_value_t = 200_000)]
    samples: usize,
    /// Seed of the distance samples; with the same seed and sample count,
    /// the benchmark's quality.py measures at the same points.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Override the format detection of INPUT.
    #[arg(long)]
    format: Option<Format>,
    /// Print the statistics as JSON and nothing else on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct RemeshArgs {
    /// The input mesh file.
    input: PathBuf,
    /// The output file; its extension chooses the format.
    output: PathBuf,
    #[command(flatten)]
    params: Params,
    /// Same as `--preserve-features false`.
    #[arg(long, conflicts_with = "preserve_features")]
    no_features: bool,
    /// Same as `--sizing adaptive`.
    #[arg(long, conflicts_with = "sizing")]
    adaptive: bool,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Write input and output statistics as JSON to this file.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Override the format detection of INPUT.
    #[arg(long)]
    format: Option<Format>,
}

/// A failure, already phrased as the one line the user sees.
struct Failure(String);

fn fail(path: &Path, e: impl std::fmt::Display) -> Failure {
    Failure(format!("{}: {e}", path.display()))
}

fn read_file(path: &Path) -> Result<Vec<u8>, Failure> {
    std::fs::read(path).map_err(|e| fail(path, e))
}

fn load(path: &Path, format: Option<Format>) -> Result<pipeline::LoadedInput, Failure> {
    let bytes = read_file(path)?;
    let name = path.file_name().and_then(|n| n.to_str());
    let mut read = ReadOptions::default();
    if let Ok(f) = Format::detect(name, &bytes, format) {
        read.external_buffers = companion_files(path, &bytes, f)?;
    }
    pipeline::load(&bytes, name, format, &read).map_err(|e| fail(path, e))
}

/// The CLI, unlike the library, reads the files a model names beside it (a
/// `.gltf`'s buffers and images, an OBJ's material libraries and their
/// maps): plain relative paths inside the model's directory only. A name
/// that would leave it is refused; a missing optional file (an OBJ's
/// material library) is left for the reader to note.
fn companion_files(
    path: &Path,
    bytes: &[u8],
    format: Format,
) -> Result<HashMap<String, Vec<u8>>, Failure> {
    let mut out = HashMap::new();
    let mut tried = std::collections::HashSet::new();
    let dir = path.parent().unwrap_or(Path::new("."));
    loop {
        let wanted: Vec<Companion> = companion_names(bytes, format, &out)
            .into_iter()
            .filter(|c| tried.insert(c.name.clone()))
            .collect();
        if wanted.is_empty() {
            return Ok(out);
        }
        for c in wanted {
            if !is_plain_relative(&c.path) {
                return Err(fail(
                    path,
                    format!("refusing to read {:?}: a model may only name files inside its own directory", c.name),
                ));
            }
            let file = dir.join(&c.path);
            match std::fs::read(&file) {
                Ok(b) => {
                    out.insert(c.name, b);
                }
                Err(e) if !c.required && e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(fail(&file, e)),
            }
        }
    }
}

fn stats_command(a: StatsArgs) -> Result<(), Failure> {
    let input = load(&a.input, a.format)?;
    let mesh = &input.source;
    let reference = match &a.reference {
        Some(p) => Some(load(p, None)?),
        None => None,
    };
    if let Some(l) = a.target_edge_length {
        if !(l.is_finite() && l > 0.0) {
            return Err(Failure(format!(
                "--target-edge-length must be positive, got {l}"
            )));
        }
    }
    let s = stats::compute(
        mesh,
        &StatsOptions {
            target_edge_length: a.target_edge_length,
            reference: reference.as_ref().map(|r| &r.source),
            samples_per_side: a.samples,
            sample_seed: a.seed,
            repairs: Some(input.repairs),
            features: Some(Default::default()),
            ..Default::default()
        },
    );
    if a.json {
        let text = serde_json::to_string_pretty(&s).map_err(|e| Failure(e.to_string()))?;
        println!("{text}");
    } else {
        println!("{} ({})", a.input.display(), input.format);
        print!("{}", s.summary());
    }
    Ok(())
}

/// Shows a progress bar on a terminal; silent otherwise.
struct Bar(Option<indicatif::ProgressBar>);

impl Observer for Bar {
    fn progress(&mut self, p: &Progress) {
        if let Some(bar) = &self.0 {
            bar.set_position((p.fraction * 1000.0) as u64);
            bar.set_message(format!(
                "iteration {}/{} {:?}",
                p.iteration, p.iterations, p.pass
            ));
        }
    }
}

fn remesh_command(a: RemeshArgs) -> Result<(), Failure> {
    let mut params = a.params;
    params.preserve_features &= !a.no_features;
    if a.adaptive {
        params.sizing = Sizing::Adaptive;
    }
    let out_format = match params.output_format {
        Some(f) => f,
        None => Format::from_extension(&a.output.to_string_lossy()).ok_or_else(|| {
            fail(
                &a.output,
                "unknown output format: use .obj, .gltf, .glb, .stl, .ply or .off, or --output-format",
            )
        })?,
    };
    let o = params
        .to_options(a.threads, DEFAULT_MAX_OUTPUT_FACES)
        .map_err(|e| Failure(e.to_string()))?;
    if o.quality_attributes && !out_format.stores_attributes() {
        return Err(fail(
            &a.output,
            format!("--quality-attributes needs glTF, GLB or PLY output, not {out_format}"),
        ));
    }
    let input = pipeline::prepare(&load(&a.input, a.format)?, &o);
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(1000);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let mut observer = Bar(bar);
    let result =
        pipeline::remesh_only(&input, &o, &mut observer).map_err(|e: JobError| fail(&a.input, e));
    if let Some(b) = &observer.0 {
        b.finish_and_clear();
    }
    let remeshed = result?;
    let attributes = if o.quality_attributes {
        pipeline::quality_attributes(&remeshed, &o)
    } else {
        Default::default()
    };
    write_output(&a.output, &remeshed, out_format, &attributes)?;
    if let Some(path) = &a.stats {
        let stats = pipeline::measure(&input, &remeshed, &o);
        print!("{}", stats.headline.render());
        let doc = serde_json::json!({
            "headline": stats.headline,
            "input": stats.input,
            "output": stats.output,
            "attributes": stats.attributes,
            "report": remeshed.out.report,
        });
        let text = serde_json::to_vec_pretty(&doc).map_err(|e| Failure(e.to_string()))?;
        std::fs::write(path, text).map_err(|e| fail(path, e))?;
    }
    Ok(())
}

/// Writes the result to `output`, and beside it any companion files its
/// format needs (an OBJ's `.mtl` and texture images).
fn write_output(
    output: &Path,
    remeshed: &pipeline::Remeshed,
    format: Format,
    attributes: &isoremesh::io::Attributes,
) -> Result<(), Failure> {
    let stem = output
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("mesh");
    let files = pipeline::encode_files(&remeshed.written, format, attributes, stem)
        .map_err(|e| fail(output, e))?;
    let dir = output.parent().unwrap_or(Path::new("."));
    for (k, (name, bytes)) in files.into_iter().enumerate() {
        let path = if k == 0 {
            output.to_path_buf()
        } else {
            dir.join(&name)
        };
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|e| fail(parent, e))?;
        }
        std::fs::write(&path, bytes).map_err(|e| fail(&path, e))?;
    }
    Ok(())
}

#[cfg(feature = "service")]
fn serve_command(config: isoremesh::service::ServiceConfig) -> Result<(), Failure> {
    isoremesh::service::telemetry::init(config.log_json);
    config.validate().map_err(|e| Failure(e.to_string()))?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("isoremesh-http")
        .build()
        .map_err(|e| Failure(format!("cannot start the async runtime: {e}")))?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(config.listen)
            .await
            .map_err(|e| Failure(format!("cannot listen on {}: {e}", config.listen)))?;
        let addr = listener
            .local_addr()
            .map_err(|e| Failure(format!("cannot read the bound address: {e}")))?;
        tracing::info!(%addr, "listening on http://{addr}");
        isoremesh::service::run(listener, config, shutdown_signal())
            .await
            .map_err(|e| Failure(e.to_string()))
    })?;
    tracing::info!("stopped");
    Ok(())
}

#[cfg(feature = "service")]
fn new_key_command(a: NewKeyArgs) -> Result<(), Failure> {
    use isoremesh::service::auth::{append_new_key, KeyLine};
    let entry = KeyLine {
        name: a.name,
        sha256: String::new(),
        max_active_jobs: a.max_active_jobs,
        requests_per_second: a.requests_per_second,
        burst: a.burst,
        max_stored_bytes: a.max_stored_bytes,
    };
    let key = append_new_key(&a.file, entry).map_err(|e| Failure(e.to_string()))?;
    println!("{key}");
    eprintln!(
        "isoremesh: the key is shown only now; {} holds its hash (send SIGHUP to a running server to read it)",
        a.file.display()
    );
    Ok(())
}

/// Completes on Ctrl-C or, on Unix, SIGTERM.
#[cfg(feature = "service")]
async fn shutdown_signal() {
    let ctrl_c = async {
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
    tracing::info!("shutdown signal received");
}

/// mimalloc keeps freed memory for reuse: the passes allocate and drop
/// buffers of the mesh's size every iteration, and the system allocator
/// returns those to the kernel and faults them in again each time.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Turns transparent huge pages off for this process.
///
/// mimalloc commits its arenas eagerly and asks for huge pages, so a small
/// remesh faults in and zeroes far more memory than it touches; on memory
/// just released by another process (the normal case for a CLI in a
/// pipeline) those faults dominate a short run. Figures in
/// `docs/BENCHMARKS.md`.
#[cfg(target_os = "linux")]
fn disable_transparent_huge_pages() {
    // SAFETY: PR_SET_THP_DISABLE takes plain integers and reads or writes no
    // memory of ours; a failure (an old kernel) only leaves the default on.
    unsafe {
        libc::prctl(libc::PR_SET_THP_DISABLE, 1, 0, 0, 0);
    }
}

fn main() -> ExitCode {
    #[cfg(target_os = "linux")]
    disable_transparent_huge_pages();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Stats(a) => stats_command(a),
        Command::Remesh(a) => remesh_command(*a),
        #[cfg(feature = "service")]
        Command::Serve(c) => serve_command(*c),
        #[cfg(feature = "service")]
        Command::Keys(KeysCommand::New(a)) => new_key_command(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure(msg)) => {
            eprintln!("isoremesh: {msg}");
            ExitCode::FAILURE
        }
    }
}

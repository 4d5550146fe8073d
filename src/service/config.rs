//! The service's configuration: every knob is a `serve` flag with a matching
//! `ISOREMESH_*` environment variable (clap's `env`), documented with its
//! default in the README's "Service" section. Limits are resolved and checked
//! once here, so the rest of the service reads plain numbers.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

/// Default listen address.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:8080";
/// Default data directory.
pub const DEFAULT_DATA_DIR: &str = "./data";
/// Default number of queued jobs waiting for a worker.
pub const DEFAULT_QUEUE_CAPACITY: usize = 64;
/// Default largest request body: 256 MiB.
pub const DEFAULT_MAX_BODY_BYTES: u64 = 256 << 20;
/// Default deadline for receiving a whole upload.
pub const DEFAULT_UPLOAD_TIMEOUT_SECS: u64 = 300;
/// Default largest input, in triangles as read.
pub const DEFAULT_MAX_INPUT_TRIANGLES: u64 = 20_000_000;
/// Default largest estimated output, in triangles.
pub const DEFAULT_MAX_OUTPUT_TRIANGLES: u64 = 20_000_000;
/// Default memory budget of the parsed inputs kept for queued jobs: 1 GiB.
pub const DEFAULT_MAX_PREPARED_BYTES: u64 = 1 << 30;
/// Default wall-time limit of one job.
pub const DEFAULT_JOB_TIMEOUT_SECS: u64 = 3600;
/// Default number of times a job may be started before an interruption
/// (a crash or a kill while it runs) fails it instead of queueing it again.
pub const DEFAULT_MAX_ATTEMPTS: u32 = 3;
/// Default cap on open HTTP connections.
pub const DEFAULT_MAX_CONNECTIONS: usize = 1024;
/// Default deadline for a request head, which also bounds keep-alive idling.
pub const DEFAULT_HEADER_TIMEOUT_SECS: u64 = 10;
/// Default cap on uploads being received, parsed and stored at once.
pub const DEFAULT_MAX_UPLOADS_IN_FLIGHT: u64 = 16;
/// Default cap on the bytes of those uploads together: 1 GiB.
pub const DEFAULT_MAX_UPLOAD_BYTES_IN_FLIGHT: u64 = 1 << 30;
/// Default free space kept in the data directory: 256 MiB.
pub const DEFAULT_MIN_FREE_BYTES: u64 = 256 << 20;
/// Default lifetime of a finished job and its result.
pub const DEFAULT_RESULT_TTL_SECS: u64 = 86_400;
/// Default time running jobs get to finish at shutdown.
pub const DEFAULT_SHUTDOWN_GRACE_SECS: u64 = 30;

/// Flags of `isoremesh serve`, each with an `ISOREMESH_*` environment variable.
#[derive(Clone, Debug, clap::Args)]
pub struct ServiceConfig {
    /// Address to listen on.
    #[arg(long, env = "ISOREMESH_LISTEN", default_value = DEFAULT_LISTEN)]
    pub listen: SocketAddr,
    /// Directory for uploads, job records and results (created if missing).
    #[arg(long, env = "ISOREMESH_DATA_DIR", default_value = DEFAULT_DATA_DIR)]
    pub data_dir: PathBuf,
    /// Jobs remeshed at the same time (default: the number of cores).
    #[arg(long, env = "ISOREMESH_WORKERS")]
    pub workers: Option<usize>,
    /// Jobs that may wait for a worker; beyond it submissions get 503.
    #[arg(long, env = "ISOREMESH_QUEUE_CAPACITY", default_value_t = DEFAULT_QUEUE_CAPACITY)]
    pub queue_capacity: usize,
    /// Largest request body in bytes; larger uploads get 413.
    #[arg(long, env = "ISOREMESH_MAX_BODY_BYTES", default_value_t = DEFAULT_MAX_BODY_BYTES)]
    pub max_body_bytes: u64,
    /// Deadline in seconds for receiving a whole upload; slower uploads get 408.
    #[arg(long, env = "ISOREMESH_UPLOAD_TIMEOUT_SECS", default_value_t = DEFAULT_UPLOAD_TIMEOUT_SECS)]
    pub upload_timeout_secs: u64,
    /// Largest input mesh in triangles; larger inputs get 413.
    #[arg(long, env = "ISOREMESH_MAX_INPUT_TRIANGLES", default_value_t = DEFAULT_MAX_INPUT_TRIANGLES)]
    pub max_input_triangles: u64,
    /// Largest estimated output in triangles; larger estimates get 422.
    #[arg(long, env = "ISOREMESH_MAX_OUTPUT_TRIANGLES", default_value_t = DEFAULT_MAX_OUTPUT_TRIANGLES)]
    pub max_output_triangles: u64,
    /// Wall-time limit of one job in seconds; a job past it fails.
    #[arg(long, env = "ISOREMESH_JOB_TIMEOUT_SECS", default_value_t = DEFAULT_JOB_TIMEOUT_SECS)]
    pub job_timeout_secs: u64,
    /// Bytes of parsed inputs kept in memory for queued jobs, so that a
    /// worker need not parse an upload again; past it a worker parses the
    /// stored upload.
    #[arg(long, env = "ISOREMESH_MAX_PREPARED_BYTES", default_value_t = DEFAULT_MAX_PREPARED_BYTES)]
    pub max_prepared_bytes: u64,
    /// Times a job may be started: a job whose run was interrupted (the
    /// process crashed or was killed) this often fails with a
    /// `too-many-attempts` problem at the next start instead of running
    /// again, so that a job that crashes the process cannot crash-loop it.
    #[arg(long, env = "ISOREMESH_MAX_ATTEMPTS", default_value_t = DEFAULT_MAX_ATTEMPTS)]
    pub max_attempts: u32,
    /// Most HTTP connections open at once. At the cap a new connection closes
    /// the oldest idle one; when every one is busy it gets a
    /// `too-many-connections` 503.
    #[arg(long, env = "ISOREMESH_MAX_CONNECTIONS", default_value_t = DEFAULT_MAX_CONNECTIONS)]
    pub max_connections: usize,
    /// Seconds a client has to send a request's head (request line and
    /// headers), counted from when the server waits for it: on a new
    /// connection, and between requests on a kept-alive one, so it also
    /// closes idle connections.
    #[arg(long, env = "ISOREMESH_HEADER_TIMEOUT_SECS", default_value_t = DEFAULT_HEADER_TIMEOUT_SECS)]
    pub header_timeout_secs: u64,
    /// Seconds a finished job and its result are kept before they expire.
    #[arg(long, env = "ISOREMESH_RESULT_TTL_SECS", default_value_t = DEFAULT_RESULT_TTL_SECS)]
    pub result_ttl_secs: u64,
    /// Seconds running jobs get to finish on SIGTERM/Ctrl-C before they are
    /// stopped and kept queued for the next start.
    #[arg(long, env = "ISOREMESH_SHUTDOWN_GRACE_SECS", default_value_t = DEFAULT_SHUTDOWN_GRACE_SECS)]
    pub shutdown_grace_secs: u64,
    /// Uploads received, parsed and stored at once; more get a
    /// `uploads-busy` 503.
    #[arg(long, env = "ISOREMESH_MAX_UPLOADS_IN_FLIGHT", default_value_t = DEFAULT_MAX_UPLOADS_IN_FLIGHT)]
    pub max_uploads_in_flight: u64,
    /// Bytes of the uploads in flight together; an upload whose bytes would
    /// pass it gets a `uploads-busy` 503. At least `--max-body-bytes`.
    #[arg(long, env = "ISOREMESH_MAX_UPLOAD_BYTES_IN_FLIGHT", default_value_t = DEFAULT_MAX_UPLOAD_BYTES_IN_FLIGHT)]
    pub max_upload_bytes_in_flight: u64,
    /// Bytes that must stay free in the data directory: below it `/readyz`
    /// answers 503, and a submission that would pass it gets 507.
    #[arg(long, env = "ISOREMESH_MIN_FREE_BYTES", default_value_t = DEFAULT_MIN_FREE_BYTES)]
    pub min_free_bytes: u64,
    /// API key file (made by `isoremesh keys new`): when set, every `/v1`
    /// request needs `Authorization: Bearer <key>` and each key sees only
    /// its own jobs. Re-read on SIGHUP. Without it the service is open.
    #[arg(long = "api-keys", env = "ISOREMESH_API_KEYS_FILE")]
    pub api_keys: Option<PathBuf>,
    /// Log as JSON lines instead of human-readable text.
    #[arg(long, env = "ISOREMESH_LOG_JSON")]
    pub log_json: bool,
}

/// A configuration value out of range.
#[derive(Debug, thiserror::Error)]
#[error("invalid configuration `{field}`: {message}")]
pub struct ConfigError {
    /// The flag, by its long name.
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

impl ServiceConfig {
    /// The defaults with the given data directory and an ephemeral port on
    /// loopback; what tests and embedders start from.
    pub fn for_data_dir(data_dir: impl Into<PathBuf>) -> Self {
        Self {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            data_dir: data_dir.into(),
            workers: None,
            queue_capacity: DEFAULT_QUEUE_CAPACITY,
            max_body_bytes: DEFAULT_MAX_BODY_BYTES,
            upload_timeout_secs: DEFAULT_UPLOAD_TIMEOUT_SECS,
            max_input_triangles: DEFAULT_MAX_INPUT_TRIANGLES,
            max_output_triangles: DEFAULT_MAX_OUTPUT_TRIANGLES,
            job_timeout_secs: DEFAULT_JOB_TIMEOUT_SECS,
            max_prepared_bytes: DEFAULT_MAX_PREPARED_BYTES,
            max_attempts: DEFAULT_MAX_ATTEMPTS,
            max_connections: DEFAULT_MAX_CONNECTIONS,
            header_timeout_secs: DEFAULT_HEADER_TIMEOUT_SECS,
            result_ttl_secs: DEFAULT_RESULT_TTL_SECS,
            shutdown_grace_secs: DEFAULT_SHUTDOWN_GRACE_SECS,
            max_uploads_in_flight: DEFAULT_MAX_UPLOADS_IN_FLIGHT,
            max_upload_bytes_in_flight: DEFAULT_MAX_UPLOAD_BYTES_IN_FLIGHT,
            api_keys: None,
            min_free_bytes: DEFAULT_MIN_FREE_BYTES,
            log_json: false,
        }
    }

    /// Checks every limit; the error names the flag.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |field, message: &str| {
            Err(ConfigError {
                field,
                message: message.to_string(),
            })
        };
        if self.workers == Some(0) || self.workers.is_some_and(|w| w > 1024) {
            return bad("workers", "must be between 1 and 1024");
        }
        if self.queue_capacity == 0 {
            return bad("queue-capacity", "must be at least 1");
        }
        if self.max_body_bytes == 0 || usize::try_from(self.max_body_bytes).is_err() {
            return bad("max-body-bytes", "must be positive and fit in memory");
        }
        if self.upload_timeout_secs == 0 {
            return bad("upload-timeout-secs", "must be at least 1");
        }
        if self.max_input_triangles == 0 {
            return bad("max-input-triangles", "must be at least 1");
        }
        if self.max_output_triangles == 0 {
            return bad("max-output-triangles", "must be at least 1");
        }
        if self.max_connections == 0 {
            return bad("max-connections", "must be at least 1");
        }
        if self.header_timeout_secs == 0 {
            return bad("header-timeout-secs", "must be at least 1");
        }
        if self.max_attempts == 0 {
            return bad("max-attempts", "must be at least 1");
        }
        if self.job_timeout_secs == 0 {
            return bad("job-timeout-secs", "must be at least 1");
        }
        if self.max_uploads_in_flight == 0 {
            return bad("max-uploads-in-flight", "must be at least 1");
        }
        if self.max_upload_bytes_in_flight < self.max_body_bytes {
            return bad(
                "max-upload-bytes-in-flight",
                "must be at least --max-body-bytes, or no upload of the largest size could pass",
            );
        }
        if self.result_ttl_secs == 0 {
            return bad("result-ttl-secs", "must be at least 1");
        }
        Ok(())
    }

    /// Worker count: the flag, or the number of cores.
    pub fn worker_count(&self) -> usize {
        self.workers.unwrap_or_else(cores)
    }

    /// Rayon threads each job may use, so that all workers together use
    /// about the machine's cores instead of each job taking all of them.
    pub fn threads_per_job(&self) -> usize {
        (cores() / self.worker_count().max(1)).max(1)
    }

    /// The upload deadline.
    pub fn upload_timeout(&self) -> Duration {
        Duration::from_secs(self.upload_timeout_secs)
    }

    /// The per-job wall-time limit.
    pub fn job_timeout(&self) -> Duration {
        Duration::from_secs(self.job_timeout_secs)
    }

    /// The shutdown grace period.
    pub fn shutdown_grace(&self) -> Duration {
        Duration::from_secs(self.shutdown_grace_secs)
    }
}

fn cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

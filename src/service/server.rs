//! The running service: the [`Service`] object that owns configuration,
//! store, job registry, queue, workers and metrics, and the [`serve`] and
//! [`run`] entry points that open it, serve HTTP on a listener, expire
//! results in the background and drain the workers on shutdown.

use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use super::auth::{Auth, KeyFileError};
use super::config::{self, ServiceConfig};
use super::connections::{serve_connections, ConnectionLimits};
use super::jobs::{now_ms, CancelReason, Job, JobStatus, Registry};
use super::metrics::{Gauges, Metrics};
use super::prepared::PreparedBudget;
use super::problem::{Problem, ProblemKind};
use super::queue::{self, JobQueue, WorkerContext};
use super::routes::app;
use super::store::Store;
use super::upload::UploadGate;

/// Shared state of a running service; handlers get it as `State<AppState>`.
pub type AppState = Arc<Service>;

/// How long expired jobs are still answered with 410 before they are
/// forgotten: the TTL again, but at least an hour.
const MIN_TOMBSTONE_MS: u64 = 3_600_000;

/// Why the service could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// A configuration value is out of range.
    #[error(transparent)]
    Config(#[from] config::ConfigError),
    /// The API key file cannot be used.
    #[error("cannot use the API key file: {0}")]
    Keys(#[from] KeyFileError),
    /// The data directory or a socket failed.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// The OS error.
        source: std::io::Error,
    },
}

fn io_err(context: impl Into<String>) -> impl FnOnce(std::io::Error) -> StartError {
    let context = context.into();
    move |source| StartError::Io { context, source }
}

/// The service: configuration, store, jobs, queue, workers and metrics.
#[derive(Debug)]
pub struct Service {
    /// The configuration.
    pub config: ServiceConfig,
    /// The data directory.
    pub store: Store,
    /// Every known job (shared with the workers).
    pub jobs: Arc<Registry>,
    /// Jobs waiting for a worker.
    pub queue: Arc<JobQueue>,
    /// Counters (shared with the workers).
    pub metrics: Arc<Metrics>,
    /// Workers remeshing now (shared with the workers).
    pub busy: Arc<AtomicUsize>,
    /// Serialises submissions that carry an `Idempotency-Key`, so two
    /// concurrent requests with one key create one job.
    pub idempotency_gate: tokio::sync::Mutex<()>,
    /// Bounds how many uploads are parsed at once (parsing is CPU and memory).
    pub parse_permits: tokio::sync::Semaphore,
    /// The memory budget of the parsed inputs handed to the workers.
    pub prepared: Arc<PreparedBudget>,
    /// The global bounds on uploads in flight.
    pub uploads: Arc<UploadGate>,
    /// The API keys and their limits.
    pub auth: Auth,
    shutting_down: AtomicBool,
    workers: Mutex<Vec<JoinHandle<()>>>,
}

impl Service {
    /// Opens the data directory, recovers jobs and starts the workers.
    /// Blocking (file system); call it from a blocking context.
    pub fn open(config: ServiceConfig) -> Result<Arc<Service>, StartError> {
        config.validate()?;
        let auth = Auth::open(config.api_keys.as_deref())?;
        let store = Store::open(&config.data_dir).map_err(io_err(format!(
            "cannot open the data directory {}",
            config.data_dir.display()
        )))?;
        let workers = config.worker_count();
        let svc = Arc::new(Service {
            queue: JobQueue::new(config.queue_capacity),
            parse_permits: tokio::sync::Semaphore::new(workers.max(2)),
            prepared: PreparedBudget::new(config.max_prepared_bytes),
            uploads: UploadGate::new(
                config.max_uploads_in_flight,
                config.max_upload_bytes_in_flight,
            ),
            auth,
            config,
            store,
            jobs: Arc::new(Registry::default()),
            metrics: Arc::new(Metrics::default()),
            busy: Arc::new(AtomicUsize::new(0)),
            idempotency_gate: tokio::sync::Mutex::new(()),
            shutting_down: AtomicBool::new(false),
            workers: Mutex::new(Vec::new()),
        });
        svc.recover()?;
        let context = WorkerContext {
            config: svc.config.clone(),
            store: svc.store.clone(),
            jobs: Arc::clone(&svc.jobs),
            queue: Arc::clone(&svc.queue),
            metrics: Arc::clone(&svc.metrics),
            busy: Arc::clone(&svc.busy),
        };
        let handles =
            queue::spawn_workers(&context, workers).map_err(io_err("cannot start workers"))?;
        *svc.workers.lock().unwrap_or_else(|p| p.into_inner()) = handles;
        tracing::info!(
            workers,
            queue_capacity = svc.config.queue_capacity,
            data_dir = %svc.config.data_dir.display(),
            "service started"
        );
        Ok(svc)
    }

    /// Loads every record; jobs that were queued or running when the
    /// previous process stopped are queued again, oldest first.
    fn recover(&self) -> Result<(), StartError> {
        let mut records = self
            .store
            .load_all()
            .map_err(io_err("cannot read the data directory"))?;
        records.sort_by(|a, b| (a.created_ms, &a.id).cmp(&(b.created_ms, &b.id)));
        let mut requeued = 0;
        let mut failed = 0;
        for mut r in records {
            let mut gave_up = false;
            if r.status == JobStatus::Running {
                if r.attempts >= self.config.max_attempts {
                    let problem = Problem::new(
                        ProblemKind::TooManyAttempts,
                        format!(
                            "the job was interrupted {} times while running (the service stopped \
                             or crashed); at most {} attempts are made",
                            r.attempts, self.config.max_attempts
                        ),
                    );
                    r.fail(now_ms(), self.config.result_ttl_secs * 1000, problem);
                    tracing::error!(job_id = %r.id, attempts = r.attempts, "job interrupted too often; failed");
                    failed += 1;
                    gave_up = true;
                } else {
                    r.requeue();
                    tracing::warn!(job_id = %r.id, attempts = r.attempts, "job was interrupted while running; queued again");
                }
            }
            let pending = !r.status.is_finished();
            let id = r.id.clone();
            let job = Arc::new(Job::new(r));
            self.jobs.insert(Arc::clone(&job));
            if pending {
                self.persist(&job);
                self.queue.push_recovered(id);
                requeued += 1;
            } else if gave_up {
                self.persist(&job);
            }
        }
        if requeued > 0 {
            tracing::info!(jobs = requeued, "re-queued unfinished jobs");
        }
        if failed > 0 {
            tracing::warn!(jobs = failed, "failed jobs interrupted too often");
        }
        Ok(())
    }

    /// Writes a job's record unless it was deleted; failures are logged.
    pub fn persist(&self, job: &Job) {
        self.store.persist(job);
    }

    /// Removes a job and its files (it must already be unreachable for
    /// workers); a failure is logged and returned.
    pub fn remove(&self, job: &Job) -> std::io::Result<()> {
        job.mark_deleted();
        let _g = job.persist_lock.lock().unwrap_or_else(|p| p.into_inner());
        let id = job.id();
        self.store.remove_job(&id).inspect_err(|e| {
            tracing::error!(job_id = %id, error = %e, "cannot remove job files");
        })
    }

    /// Whether shutdown has begun.
    pub fn is_shutting_down(&self) -> bool {
        self.shutting_down.load(Ordering::SeqCst)
    }

    /// Stops accepting jobs and stops handing queued jobs to workers.
    pub fn begin_shutdown(&self) {
        if !self.shutting_down.swap(true, Ordering::SeqCst) {
            tracing::info!("shutting down: no new jobs; running jobs may finish");
        }
        self.queue.close();
    }

    /// Waits for running jobs up to `grace`, then stops the rest (they stay
    /// queued on disk) and joins the workers.
    pub async fn drain(self: &Arc<Self>, grace: Duration) {
        self.begin_shutdown();
        let handles: Vec<_> =
            std::mem::take(&mut *self.workers.lock().unwrap_or_else(|p| p.into_inner()));
        let join = tokio::task::spawn_blocking(move || {
            for h in handles {
                let _ = h.join();
            }
        });
        tokio::pin!(join);
        if tokio::time::timeout(grace, &mut join).await.is_err() {
            let mut stopped = 0;
            for job in self.jobs.all() {
                if job.status() == JobStatus::Running {
                    job.request_cancel(CancelReason::Shutdown);
                    stopped += 1;
                }
            }
            tracing::warn!(
                jobs = stopped,
                "grace period over; stopping running jobs, kept queued"
            );
            let _ = join.await;
        }
        tracing::info!("workers stopped");
    }

    /// Expires finished jobs: at `expires_ms` their files are removed (the
    /// record stays, and the result answers 410); a tombstone period later
    /// the record goes too.
    pub fn sweep(&self, now: u64) {
        let keep = (self.config.result_ttl_secs * 1000).max(MIN_TOMBSTONE_MS);
        for job in self.jobs.all() {
            let r = job.snapshot();
            let Some(expires) = r.expires_ms else {
                continue;
            };
            if !r.status.is_finished() || now < expires {
                continue;
            }
            if now >= expires.saturating_add(keep) {
                if self.jobs.remove(&r.id).is_some() {
                    let _ = self.remove(&job);
                    tracing::info!(job_id = %r.id, "expired job forgotten");
                }
            } else if !r.result_expired {
                let guard = job.persist_lock.lock().unwrap_or_else(|p| p.into_inner());
                if job.is_deleted() {
                    continue;
                }
                if let Err(e) = self.store.remove_files(&r.id) {
                    tracing::error!(job_id = %r.id, error = %e, "cannot remove expired files");
                    continue;
                }
                job.update(|r| r.result_expired = true);
                drop(guard);
                self.persist(&job);
                tracing::info!(job_id = %r.id, "job expired; files removed");
            }
        }
    }

    /// Current gauges for metrics and health.
    pub fn gauges(&self) -> Gauges {
        Gauges {
            queue_depth: self.queue.depth(),
            queue_capacity: self.queue.capacity(),
            workers_busy: self.busy.load(Ordering::SeqCst),
            workers: self.config.worker_count(),
            jobs: self.jobs.count_by_status(),
            prepared_bytes: self.prepared.held(),
            uploads_in_flight: self.uploads.in_flight().0,
            upload_bytes_in_flight: self.uploads.in_flight().1,
        }
    }
}

async fn sweeper(svc: AppState) {
    let period = Duration::from_secs((svc.config.result_ttl_secs / 2).clamp(1, 60));
    loop {
        tokio::time::sleep(period).await;
        let s = Arc::clone(&svc);
        let _ = tokio::task::spawn_blocking(move || s.sweep(now_ms())).await;
    }
}

/// Re-reads the API key file on every SIGHUP; a file that cannot be used
/// is logged and the keys in use stay.
async fn reload_keys_on_hangup(svc: AppState) {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        if !svc.auth.enabled() {
            return;
        }
        let Ok(mut hangups) = signal(SignalKind::hangup()) else {
            tracing::warn!("cannot listen for SIGHUP; the API key file is read only at start");
            return;
        };
        while hangups.recv().await.is_some() {
            let s = Arc::clone(&svc);
            match tokio::task::spawn_blocking(move || s.auth.reload()).await {
                Ok(Ok(keys)) => tracing::info!(keys, "API key file re-read"),
                Ok(Err(e)) => {
                    tracing::error!(error = %e, "API key file not re-read; the previous keys stay")
                }
                Err(e) => tracing::error!(error = %e, "API key reload failed"),
            }
        }
    }
    #[cfg(not(unix))]
    let _ = svc;
}

/// Serves an opened service on `listener` until `shutdown` completes, then
/// stops accepting, lets running jobs finish within the grace period and
/// leaves the rest queued for the next start.
pub async fn serve(
    listener: tokio::net::TcpListener,
    svc: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    match listener.local_addr() {
        Ok(addr) if !svc.auth.enabled() && !addr.ip().is_loopback() => tracing::warn!(
            listen = %addr,
            "no API keys are configured (--api-keys) and the service listens beyond loopback: \
             anyone who can reach it can submit, read and delete every job"
        ),
        _ => {}
    }
    let sweeper = tokio::spawn(sweeper(Arc::clone(&svc)));
    let reloader = tokio::spawn(reload_keys_on_hangup(Arc::clone(&svc)));
    let on_signal = {
        let svc = Arc::clone(&svc);
        async move {
            shutdown.await;
            svc.begin_shutdown();
        }
    };
    let limits = ConnectionLimits {
        max_connections: svc.config.max_connections,
        header_timeout: Duration::from_secs(svc.config.header_timeout_secs),
    };
    let served = serve_connections(
        listener,
        app(Arc::clone(&svc)),
        limits,
        Arc::clone(&svc.metrics),
        on_signal,
        svc.config.shutdown_grace(),
    )
    .await;
    sweeper.abort();
    reloader.abort();
    svc.drain(svc.config.shutdown_grace()).await;
    served
}

/// Opens the service described by `config` and serves it on `listener`
/// until `shutdown` completes (see [`serve`]). Tests bind port 0.
pub async fn run(
    listener: tokio::net::TcpListener,
    config: ServiceConfig,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), StartError> {
    let svc = tokio::task::spawn_blocking(move || Service::open(config))
        .await
        .map_err(|e| StartError::Io {
            context: "startup task failed".into(),
            source: std::io::Error::other(e),
        })??;
    serve(listener, svc, shutdown)
        .await
        .map_err(io_err("server failed"))
}

//! The bounded job queue and the fixed worker pool. Submissions first
//! reserve a slot ([`JobQueue::try_reserve`]), so a full queue refuses a job
//! before anything is written, and commit the job id once it is stored.
//! Workers are plain OS threads that block on the queue: remeshing never runs
//! on the async runtime. Each job runs under `catch_unwind`, with an
//! [`Observer`] that publishes progress into the job and stops the remesh on
//! a cancel request or when the job's wall-time limit passes.

use std::collections::VecDeque;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Instant;

use sha2::{Digest, Sha256};

use super::config::ServiceConfig;
use super::jobs::{now_ms, CancelReason, Job, JobRecord, Registry, ResultInfo};
use super::metrics::{Metrics, Outcome};
use super::prepared::Prepared;
use super::problem::{Problem, ProblemKind};
use super::store::Store;
use crate::io::ReadOptions;
use crate::pipeline::{self, JobError, JobStats};
use crate::remesh::{Observer, Pass, Progress, RemeshError};

/// A FIFO of job ids with a capacity that counts reserved slots.
#[derive(Debug)]
pub struct JobQueue {
    inner: Mutex<Inner>,
    ready: Condvar,
    capacity: usize,
}

#[derive(Debug, Default)]
struct Inner {
    items: VecDeque<String>,
    reserved: usize,
    closed: bool,
}

/// A reserved queue slot; dropping it without [`Reservation::commit`] frees it.
#[derive(Debug)]
pub struct Reservation {
    queue: Arc<JobQueue>,
    committed: bool,
}

impl Reservation {
    /// Enqueues the job in the reserved slot.
    pub fn commit(mut self, id: String) {
        let mut g = self.queue.lock();
        g.reserved -= 1;
        g.items.push_back(id);
        self.committed = true;
        drop(g);
        self.queue.ready.notify_one();
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        if !self.committed {
            self.queue.lock().reserved -= 1;
        }
    }
}

impl JobQueue {
    /// An empty queue.
    pub fn new(capacity: usize) -> Arc<Self> {
        Arc::new(Self {
            inner: Mutex::new(Inner::default()),
            ready: Condvar::new(),
            capacity,
        })
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Reserves a slot, or `None` when the queue is full or closed.
    pub fn try_reserve(self: &Arc<Self>) -> Option<Reservation> {
        let mut g = self.lock();
        if g.closed || g.items.len() + g.reserved >= self.capacity {
            return None;
        }
        g.reserved += 1;
        Some(Reservation {
            queue: Arc::clone(self),
            committed: false,
        })
    }

    /// Enqueues a recovered job regardless of capacity: jobs accepted before
    /// a restart keep their place.
    pub fn push_recovered(&self, id: String) {
        self.lock().items.push_back(id);
        self.ready.notify_one();
    }

    /// Takes the next job id, blocking; `None` once the queue is closed.
    pub fn pop(&self) -> Option<String> {
        let mut g = self.lock();
        loop {
            if g.closed {
                return None;
            }
            if let Some(id) = g.items.pop_front() {
                return Some(id);
            }
            g = self.ready.wait(g).unwrap_or_else(|p| p.into_inner());
        }
    }

    /// Removes a waiting job; whether it was waiting.
    pub fn remove(&self, id: &str) -> bool {
        let mut g = self.lock();
        let before = g.items.len();
        g.items.retain(|x| x != id);
        before != g.items.len()
    }

    /// Jobs waiting (reserved slots included).
    pub fn depth(&self) -> usize {
        let g = self.lock();
        g.items.len() + g.reserved
    }

    /// The capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Stops handing out jobs; waiting jobs stay stored as queued.
    pub fn close(&self) {
        self.lock().closed = true;
        self.ready.notify_all();
    }
}

/// What a worker needs from the service, and no more: the queue it takes
/// jobs from, the jobs themselves, their files, the limits and the
/// counters. HTTP-side state (idempotency, parse permits, shutdown flag)
/// stays with the [`super::server::Service`].
#[derive(Clone, Debug)]
pub struct WorkerContext {
    /// Limits and the result TTL.
    pub config: ServiceConfig,
    /// Where inputs are read and results and records written.
    pub store: Store,
    /// Every known job, to look up a popped id.
    pub jobs: Arc<Registry>,
    /// Jobs waiting for a worker.
    pub queue: Arc<JobQueue>,
    /// Counters a finished job updates.
    pub metrics: Arc<Metrics>,
    /// Workers remeshing now.
    pub busy: Arc<AtomicUsize>,
}

/// Starts `n` worker threads on `context`'s queue.
pub fn spawn_workers(context: &WorkerContext, n: usize) -> std::io::Result<Vec<JoinHandle<()>>> {
    (0..n)
        .map(|i| {
            let ctx = context.clone();
            std::thread::Builder::new()
                .name(format!("isoremesh-worker-{i}"))
                .spawn(move || {
                    while let Some(id) = ctx.queue.pop() {
                        if let Some(job) = ctx.jobs.get(&id) {
                            ctx.busy.fetch_add(1, Ordering::SeqCst);
                            run_job(&ctx, &job);
                            ctx.busy.fetch_sub(1, Ordering::SeqCst);
                        }
                    }
                })
        })
        .collect()
}

/// Publishes progress into the job and stops on cancel or timeout.
struct JobObserver<'a> {
    job: &'a Job,
    deadline: Instant,
}

impl Observer for JobObserver<'_> {
    fn progress(&mut self, p: &Progress) {
        self.job.set_progress(*p);
    }
    fn is_cancelled(&self) -> bool {
        self.job.is_cancel_requested() || Instant::now() >= self.deadline
    }
}

/// Why a run produced no result.
enum RunError {
    Job(JobError),
    Problem(Problem),
    Storage(std::io::Error),
}

impl From<JobError> for RunError {
    fn from(e: JobError) -> Self {
        RunError::Job(e)
    }
}

/// What a successful run leaves.
struct Done {
    stats: JobStats,
    result: ResultInfo,
    iterations: u32,
}

fn execute(
    ctx: &WorkerContext,
    job: &Job,
    rec: &JobRecord,
    prepared: Option<Prepared>,
    deadline: Instant,
) -> Result<Done, RunError> {
    let cfg = &ctx.config;
    // The input as submit parsed it, or (after a restart, or past the
    // budget of held inputs) the stored upload parsed again, which gives
    // the same input.
    ctx.metrics.input_loaded(prepared.is_some());
    let input = match prepared {
        Some(p) => p.input().clone(),
        None => {
            let (bytes, external_buffers) = ctx.store.read_input(rec).map_err(RunError::Storage)?;
            let read = ReadOptions {
                external_buffers,
                max_triangles: cfg.max_input_triangles,
            };
            pipeline::load(
                &bytes,
                rec.input.file_name.as_deref(),
                Some(rec.input.format),
                &read,
            )?
        }
    };
    let options = rec
        .params
        .job_options(cfg.threads_per_job(), cfg.max_output_triangles)
        .map_err(RunError::Problem)?;
    let mut observer = JobObserver { job, deadline };
    let out = pipeline::run(&input, &options, &mut observer)?;
    drop(input);
    let format = rec.params.output_format.unwrap_or(rec.input.format);
    // The model file alone; an OBJ's library and images are packed on
    // demand from the stored mesh (`bundle=zip`).
    let encoded = pipeline::encode_files(&out.mesh, format, &out.attributes, &rec.result_stem())?
        .swap_remove(0)
        .1;
    let result = ResultInfo {
        format,
        bytes: encoded.len() as u64,
        sha256: hex::encode(Sha256::digest(&encoded)),
        vertices: out.mesh.positions.len() as u64,
        triangles: out.mesh.triangles.len() as u64,
    };
    {
        // Under the persist lock so that a concurrent DELETE cannot remove
        // the directory halfway through.
        let _g = job.persist_lock.lock().unwrap_or_else(|p| p.into_inner());
        if !job.is_deleted() {
            ctx.store
                .write_result(&rec.id, format, &encoded, &out.mesh)
                .map_err(RunError::Storage)?;
        }
    }
    Ok(Done {
        stats: out.stats,
        result,
        iterations: options.iterations,
    })
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}

/// Runs `f` and turns a panic into a problem (the panic hook has already
/// logged it with the job's span).
pub fn catch_job_panic<T>(f: impl FnOnce() -> T) -> Result<T, Problem> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        tracing::error!(panic = %panic_message(payload.as_ref()), "job panicked");
        Problem::new(
            ProblemKind::Internal,
            "the remesher hit an internal error (a bug) and stopped; the details were logged under this job's id",
        )
    })
}

/// Runs one job from start to a final (or re-queued) state.
pub fn run_job(ctx: &WorkerContext, job: &Job) {
    // Taken whatever follows, so that its memory returns to the budget.
    let prepared = job.take_prepared();
    let started = job.update(|r| r.start(now_ms()).then(|| r.clone()));
    let Some(rec) = started else { return };
    let span = tracing::info_span!(
        "job",
        job_id = %rec.id,
        request_id = rec.request_id.as_deref().unwrap_or("-")
    );
    let _enter = span.enter();
    ctx.store.persist(job);
    tracing::info!(
        attempt = rec.attempts,
        triangles = rec.input.triangles,
        "job started"
    );
    let t0 = Instant::now();
    let deadline = t0 + ctx.config.job_timeout();
    let outcome = catch_job_panic(|| execute(ctx, job, &rec, prepared, deadline));
    let seconds = t0.elapsed().as_secs_f64();
    let now = now_ms();
    let ttl = ctx.config.result_ttl_secs * 1000;
    let tris_in = rec.input.triangles;
    let fail = |problem: Problem| {
        tracing::warn!(detail = %problem.detail, kind = %problem.kind, "job failed");
        job.update(|r| r.fail(now, ttl, problem));
        ctx.metrics
            .job_finished(Outcome::Failed, seconds, tris_in, 0);
    };
    match outcome {
        Ok(Ok(done)) => {
            let tris_out = done.result.triangles;
            let last = Progress {
                iteration: done.iterations,
                iterations: done.iterations,
                pass: Pass::Project,
                fraction: 1.0,
            };
            job.update(|r| r.succeed(now, ttl, last, done.stats, done.result));
            ctx.metrics
                .job_finished(Outcome::Succeeded, seconds, tris_in, tris_out);
            tracing::info!(seconds, triangles_out = tris_out, "job succeeded");
        }
        Ok(Err(RunError::Job(JobError::Remesh(RemeshError::Cancelled)))) => match job
            .cancel_reason()
        {
            CancelReason::User => {
                job.update(|r| r.cancel(now, ttl));
                ctx.metrics
                    .job_finished(Outcome::Cancelled, seconds, tris_in, 0);
                tracing::info!(seconds, "job cancelled");
            }
            CancelReason::Shutdown => {
                job.update(|r| r.requeue());
                tracing::info!("job interrupted by shutdown; it stays queued for the next start");
            }
            CancelReason::None => fail(Problem::new(
                ProblemKind::JobTimeout,
                format!(
                    "the job ran longer than the limit of {} s and was stopped",
                    ctx.config.job_timeout_secs
                ),
            )),
        },
        Ok(Err(RunError::Job(e))) => fail(Problem::from_job_error(&e)),
        Ok(Err(RunError::Problem(p))) => fail(p),
        Ok(Err(RunError::Storage(e))) => {
            if job.is_deleted() {
                return;
            }
            fail(Problem::internal(
                "the job's files could not be read or written",
                e,
            ))
        }
        Err(p) => fail(p),
    }
    ctx.store.persist(job);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reservations_count_against_capacity_until_dropped() {
        let q = JobQueue::new(2);
        let a = q.try_reserve().unwrap();
        let b = q.try_reserve().unwrap();
        assert!(q.try_reserve().is_none());
        drop(a);
        let c = q.try_reserve().unwrap();
        b.commit("b".into());
        c.commit("c".into());
        assert_eq!(q.depth(), 2);
        assert!(q.try_reserve().is_none());
        assert!(q.remove("b"));
        assert_eq!(q.pop().as_deref(), Some("c"));
        q.close();
        assert!(q.try_reserve().is_none());
        assert_eq!(q.pop(), None);
    }

    #[test]
    fn a_panicking_job_becomes_an_internal_problem() {
        let r = catch_job_panic(|| -> u32 { panic!("boom") });
        let p = r.unwrap_err();
        assert_eq!(p.status, 500);
        assert!(p.is(ProblemKind::Internal));
        assert_eq!(catch_job_panic(|| 7).unwrap(), 7);
    }
}

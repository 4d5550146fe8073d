//! Jobs: the durable record ([`JobRecord`], one `job.json` per job), its
//! state machine, and the in-memory [`Job`] that adds what only a running
//! process has: the latest progress and the cancel flag the remesh observer
//! reads. The [`Registry`] indexes jobs by id and by `Idempotency-Key`.
//!
//! States: `queued → running → succeeded | failed | cancelled`, plus
//! `queued → cancelled`, and `running → queued` when shutdown or a crash
//! interrupts a job (it runs again after the restart).

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, RwLock};
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use super::params::InputGeometry;
use super::prepared::Prepared;
use super::problem::Problem;
use crate::io::Format;
use crate::mesh::RepairReport;
use crate::params::Params;
use crate::pipeline::JobStats;
use crate::remesh::Progress;

/// Where a job is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobStatus {
    /// Waiting for a worker.
    Queued,
    /// Being remeshed.
    Running,
    /// Finished with a result.
    Succeeded,
    /// Finished with a problem.
    Failed,
    /// Stopped on request.
    Cancelled,
}

impl JobStatus {
    /// Every status, in life order.
    pub const ALL: [JobStatus; 5] = [
        JobStatus::Queued,
        JobStatus::Running,
        JobStatus::Succeeded,
        JobStatus::Failed,
        JobStatus::Cancelled,
    ];

    /// Whether the job will not change any more.
    pub fn is_finished(self) -> bool {
        matches!(
            self,
            JobStatus::Succeeded | JobStatus::Failed | JobStatus::Cancelled
        )
    }

    /// The lowercase name used in JSON, queries and metrics.
    pub fn as_str(self) -> &'static str {
        match self {
            JobStatus::Queued => "queued",
            JobStatus::Running => "running",
            JobStatus::Succeeded => "succeeded",
            JobStatus::Failed => "failed",
            JobStatus::Cancelled => "cancelled",
        }
    }

    /// Parses a lowercase status name.
    pub fn parse(s: &str) -> Option<JobStatus> {
        Self::ALL.into_iter().find(|st| st.as_str() == s)
    }
}

/// What was uploaded, as stored and summarised.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputInfo {
    /// The uploaded file name, if any.
    pub file_name: Option<String>,
    /// The detected format.
    pub format: Format,
    /// Size of the mesh upload in bytes.
    pub bytes: u64,
    /// Vertices after repair.
    pub vertices: u64,
    /// Triangles after repair.
    pub triangles: u64,
    /// Area, diagonal and mean edge length.
    pub geometry: InputGeometry,
    /// The estimated output triangle count checked before queueing.
    pub estimated_output_triangles: u64,
    /// External glTF buffers received, by `uri`, in storage order.
    pub buffers: Vec<String>,
    /// What the builder repaired.
    pub repairs: RepairReport,
}

/// The stored result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResultInfo {
    /// Format of the stored encoding.
    pub format: Format,
    /// Its size in bytes.
    pub bytes: u64,
    /// SHA-256 of those bytes, hex; the strong ETag.
    pub sha256: String,
    /// Output vertices (after splitting normals along features).
    pub vertices: u64,
    /// Output triangles.
    pub triangles: u64,
}

/// Idempotency data kept with the job, so that it survives restarts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Idempotency {
    /// The `Idempotency-Key` header.
    pub key: String,
    /// SHA-256 (hex) of the canonical request: mesh, buffers, name, params.
    pub fingerprint: String,
}

/// The durable part of a job, stored as `job.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobRecord {
    /// Job id (a UUID).
    pub id: String,
    /// Current status.
    pub status: JobStatus,
    /// Unix milliseconds of submission.
    pub created_ms: u64,
    /// Unix milliseconds the last run started.
    pub started_ms: Option<u64>,
    /// Unix milliseconds it finished.
    pub finished_ms: Option<u64>,
    /// Unix milliseconds the job and its result expire (set when finished).
    pub expires_ms: Option<u64>,
    /// The normalised parameters.
    pub params: Params,
    /// The input summary.
    pub input: InputInfo,
    /// Progress when last persisted (final progress once finished).
    pub progress: Option<Progress>,
    /// Input and output statistics once succeeded. A record written by an
    /// earlier version whose statistics have another shape keeps its job
    /// and result, with the statistics dropped (null), rather than being
    /// skipped as corrupt.
    #[serde(default, deserialize_with = "stats_or_none")]
    pub stats: Option<JobStats>,
    /// The stored result once succeeded.
    pub result: Option<ResultInfo>,
    /// Why the job failed.
    pub error: Option<Problem>,
    /// Idempotency key and request fingerprint, if the client sent a key.
    pub idempotency: Option<Idempotency>,
    /// The id of the submitting request, carried into the worker's logs.
    pub request_id: Option<String>,
    /// How many times a worker started the job.
    pub attempts: u32,
    /// Whether the sweeper removed the result files after expiry.
    pub result_expired: bool,
    /// The name of the API key that submitted the job; only that key sees
    /// it. `None` when the service ran without keys.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub owner: Option<String>,
    /// Bytes of the stored upload: the mesh and its companion parts.
    #[serde(default)]
    pub upload_bytes: u64,
}

impl JobRecord {
    /// The base name of the job's result files: the upload's file stem
    /// (ASCII letters, digits, `-` and `_`, anything else as `_`; `mesh`
    /// when there was no name) followed by `-remeshed`.
    pub fn result_stem(&self) -> String {
        let stem: String = self
            .input
            .file_name
            .as_deref()
            .and_then(|n| std::path::Path::new(n).file_stem())
            .and_then(|s| s.to_str())
            .unwrap_or("mesh")
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        format!("{stem}-remeshed")
    }

    /// `queued → running`: a worker takes the job. Returns `false` (and
    /// changes nothing) unless the job is queued, so a job cancelled or
    /// deleted while waiting is never started.
    pub fn start(&mut self, now: u64) -> bool {
        if self.status != JobStatus::Queued {
            return false;
        }
        self.status = JobStatus::Running;
        self.started_ms = Some(now);
        self.attempts += 1;
        self.progress = None;
        true
    }

    /// Marks the job finished in `status` at `now`; it expires `ttl_ms`
    /// later. Every final state goes through here so that a finished
    /// record always carries both times.
    fn finish(&mut self, status: JobStatus, now: u64, ttl_ms: u64) {
        self.status = status;
        self.finished_ms = Some(now);
        self.expires_ms = Some(now + ttl_ms);
    }

    /// `running → succeeded` with the final progress, statistics and result.
    pub fn succeed(
        &mut self,
        now: u64,
        ttl_ms: u64,
        progress: Progress,
        stats: JobStats,
        result: ResultInfo,
    ) {
        self.finish(JobStatus::Succeeded, now, ttl_ms);
        self.progress = Some(progress);
        self.stats = Some(stats);
        self.result = Some(result);
    }

    /// `running → failed` with the problem that stopped it.
    pub fn fail(&mut self, now: u64, ttl_ms: u64, problem: Problem) {
        self.finish(JobStatus::Failed, now, ttl_ms);
        self.error = Some(problem);
    }

    /// `queued | running → cancelled` on a client's request.
    pub fn cancel(&mut self, now: u64, ttl_ms: u64) {
        self.finish(JobStatus::Cancelled, now, ttl_ms);
    }

    /// `running → queued`: shutdown or a crash interrupted the job, which
    /// runs again from the start, so its progress is cleared.
    pub fn requeue(&mut self) {
        self.status = JobStatus::Queued;
        self.progress = None;
    }
}

/// Why a running job is being stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CancelReason {
    /// Not asked to stop.
    None = 0,
    /// The service is shutting down; the job is kept queued.
    Shutdown = 1,
    /// A client cancelled or deleted the job (wins over `Shutdown`).
    User = 2,
}

/// A job in memory: the record plus live progress and cancellation.
#[derive(Debug)]
pub struct Job {
    record: Mutex<JobRecord>,
    progress: Mutex<Option<Progress>>,
    cancel: AtomicU8,
    deleted: AtomicBool,
    /// Serialises writes of `job.json` so the last write holds the last state.
    pub persist_lock: Mutex<()>,
    /// The input as submit parsed it, until the worker takes it.
    prepared: Mutex<Option<Prepared>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic while holding these short locks cannot leave the record half
    // updated in a way later readers would misread, so poisoning is ignored.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Job {
    /// Wraps a record.
    pub fn new(record: JobRecord) -> Self {
        let progress = record.progress;
        Self {
            record: Mutex::new(record),
            progress: Mutex::new(progress),
            cancel: AtomicU8::new(CancelReason::None as u8),
            deleted: AtomicBool::new(false),
            persist_lock: Mutex::new(()),
            prepared: Mutex::new(None),
        }
    }

    /// A copy of the record with the live progress.
    pub fn snapshot(&self) -> JobRecord {
        let mut r = lock(&self.record).clone();
        if r.status == JobStatus::Running {
            r.progress = *lock(&self.progress);
        }
        r
    }

    /// Runs `f` on the record under its lock.
    pub fn update<T>(&self, f: impl FnOnce(&mut JobRecord) -> T) -> T {
        f(&mut lock(&self.record))
    }

    /// The job id.
    pub fn id(&self) -> String {
        lock(&self.record).id.clone()
    }

    /// The current status.
    pub fn status(&self) -> JobStatus {
        lock(&self.record).status
    }

    /// Keeps the input that submit parsed, for the worker.
    pub fn set_prepared(&self, input: Prepared) {
        *lock(&self.prepared) = Some(input);
    }

    /// Takes the input that submit parsed, if it is still held (not after a
    /// restart, nor when it did not fit in the budget).
    pub fn take_prepared(&self) -> Option<Prepared> {
        lock(&self.prepared).take()
    }

    /// Records the latest progress (called by the worker's observer).
    pub fn set_progress(&self, p: Progress) {
        *lock(&self.progress) = Some(p);
    }

    /// Asks a running job to stop.
    pub fn request_cancel(&self, reason: CancelReason) {
        // A user's cancel wins over a shutdown's, which only re-queues.
        let _ = self.cancel.fetch_max(reason as u8, Ordering::SeqCst);
    }

    /// Why the job was asked to stop.
    pub fn cancel_reason(&self) -> CancelReason {
        match self.cancel.load(Ordering::SeqCst) {
            1 => CancelReason::Shutdown,
            2 => CancelReason::User,
            _ => CancelReason::None,
        }
    }

    /// Clears a shutdown request (the job was re-queued in-process).
    pub fn clear_cancel(&self) {
        self.cancel
            .store(CancelReason::None as u8, Ordering::SeqCst);
    }

    /// Whether a stop was requested for any reason.
    pub fn is_cancel_requested(&self) -> bool {
        self.cancel.load(Ordering::Relaxed) != CancelReason::None as u8
    }

    /// Marks the job deleted so that a worker does not write its files again.
    pub fn mark_deleted(&self) {
        self.deleted.store(true, Ordering::SeqCst);
    }

    /// Whether the job was deleted.
    pub fn is_deleted(&self) -> bool {
        self.deleted.load(Ordering::SeqCst)
    }
}

/// All known jobs, by id, and the idempotency index. Idempotency keys are
/// scoped by owner: two API keys that send the same `Idempotency-Key` get
/// two jobs.
#[derive(Debug, Default)]
pub struct Registry {
    jobs: RwLock<HashMap<String, Arc<Job>>>,
    keys: Mutex<IdempotencyIndex>,
}

/// (owner, `Idempotency-Key`) → (request fingerprint, job id).
type IdempotencyIndex = HashMap<(Option<String>, String), (String, String)>;

impl Registry {
    /// Adds a job (and its idempotency key).
    pub fn insert(&self, job: Arc<Job>) {
        let r = job.snapshot();
        if let Some(i) = &r.idempotency {
            lock(&self.keys).insert(
                (r.owner.clone(), i.key.clone()),
                (i.fingerprint.clone(), r.id.clone()),
            );
        }
        self.jobs
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .insert(r.id, job);
    }

    /// The job with this id.
    pub fn get(&self, id: &str) -> Option<Arc<Job>> {
        self.jobs
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .get(id)
            .cloned()
    }

    /// Removes a job and its idempotency key.
    pub fn remove(&self, id: &str) -> Option<Arc<Job>> {
        let job = self
            .jobs
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .remove(id)?;
        lock(&self.keys).retain(|_, (_, j)| j != id);
        Some(job)
    }

    /// The (fingerprint, job id) that `owner` stored under an idempotency key.
    pub fn by_key(&self, owner: Option<&str>, key: &str) -> Option<(String, String)> {
        lock(&self.keys)
            .get(&(owner.map(str::to_string), key.to_string()))
            .cloned()
    }

    /// What `owner`'s jobs hold: (jobs queued or running, bytes stored in
    /// uploads and results whose files are still kept).
    pub fn usage(&self, owner: &str) -> (u64, u64) {
        let mut active = 0;
        let mut bytes = 0;
        for j in self.all() {
            j.update(|r| {
                if r.owner.as_deref() != Some(owner) || r.result_expired {
                    return;
                }
                if !r.status.is_finished() {
                    active += 1;
                }
                bytes +=
                    r.upload_bytes.max(r.input.bytes) + r.result.as_ref().map_or(0, |x| x.bytes);
            });
        }
        (active, bytes)
    }

    /// Every job.
    pub fn all(&self) -> Vec<Arc<Job>> {
        self.jobs
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .values()
            .cloned()
            .collect()
    }

    /// Number of jobs per status.
    pub fn count_by_status(&self) -> [u64; 5] {
        let mut counts = [0u64; 5];
        for j in self.all() {
            let s = j.status();
            if let Some(i) = JobStatus::ALL.iter().position(|&x| x == s) {
                counts[i] += 1;
            }
        }
        counts
    }
}

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

/// Formats Unix milliseconds as RFC 3339 UTC with milliseconds,
/// e.g. `2025-01-31T12:00:00.000Z` (Hinnant's civil-from-days conversion).
pub fn rfc3339(ms: u64) -> String {
    let secs = ms / 1000;
    let days = (secs / 86_400) as i64;
    let sod = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{:03}Z",
        sod / 3600,
        (sod / 60) % 60,
        sod % 60,
        ms % 1000
    )
}

/// [`JobRecord::stats`], or `None` when the stored value does not parse.
fn stats_or_none<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<JobStats>, D::Error> {
    let v = serde_json::Value::deserialize(d)?;
    Ok(serde_json::from_value(v).ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_matches_known_instants() {
        assert_eq!(rfc3339(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(951_782_400_123), "2000-02-29T00:00:00.123Z");
        assert_eq!(rfc3339(1_735_689_599_999), "2024-12-31T23:59:59.999Z");
    }

    #[test]
    fn user_cancel_wins_over_shutdown() {
        let job = Job::new(sample_record());
        job.request_cancel(CancelReason::Shutdown);
        job.request_cancel(CancelReason::User);
        job.request_cancel(CancelReason::Shutdown);
        assert_eq!(job.cancel_reason(), CancelReason::User);
    }

    #[test]
    fn a_record_with_stats_of_an_earlier_shape_keeps_its_job() {
        let mut v = serde_json::to_value(sample_record()).unwrap();
        v["stats"] = serde_json::json!({"input": {"vertices": 3}, "output": {}});
        let r: JobRecord = serde_json::from_value(v.clone()).unwrap();
        assert!(r.stats.is_none());
        assert_eq!(r.id, "j");
        // Records without the field, or with null, read as before.
        v.as_object_mut().unwrap().remove("stats");
        assert!(serde_json::from_value::<JobRecord>(v)
            .unwrap()
            .stats
            .is_none());
    }

    #[test]
    fn transitions_set_status_and_times() {
        let mut r = sample_record();
        assert!(r.start(10));
        assert_eq!(
            (r.status, r.started_ms, r.attempts),
            (JobStatus::Running, Some(10), 1)
        );
        assert!(!r.start(11), "only a queued job starts");
        r.requeue();
        assert_eq!((r.status, r.progress), (JobStatus::Queued, None));
        r.cancel(20, 5);
        assert_eq!(r.status, JobStatus::Cancelled);
        assert_eq!((r.finished_ms, r.expires_ms), (Some(20), Some(25)));
        assert!(!r.start(30));
    }

    pub(crate) fn sample_record() -> JobRecord {
        JobRecord {
            id: "j".into(),
            status: JobStatus::Queued,
            created_ms: 0,
            started_ms: None,
            finished_ms: None,
            expires_ms: None,
            params: Params::default(),
            input: InputInfo {
                file_name: None,
                format: Format::Obj,
                bytes: 0,
                vertices: 0,
                triangles: 0,
                geometry: InputGeometry {
                    area: 0.0,
                    bbox_diagonal: 0.0,
                    mean_edge_length: 0.0,
                },
                estimated_output_triangles: 0,
                buffers: vec![],
                repairs: RepairReport::default(),
            },
            progress: None,
            stats: None,
            result: None,
            error: None,
            idempotency: None,
            request_id: None,
            attempts: 0,
            result_expired: false,
            owner: None,
            upload_bytes: 0,
        }
    }
}

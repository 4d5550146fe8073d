//! The JSON documents of the API, as `openapi.yaml` describes them: the job
//! view, the list page and the health document. Records are converted here
//! (timestamps to RFC 3339, links built), so handlers never shape JSON.

use serde::{Deserialize, Serialize};

use super::jobs::{rfc3339, JobRecord, JobStatus};
use super::problem::Problem;
use crate::io::Format;
use crate::mesh::RepairReport;
use crate::params::Params;
use crate::pipeline::JobStats;
use crate::remesh::Progress;

/// The input summary of a job.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InputView {
    /// Uploaded file name, if any.
    pub file_name: Option<String>,
    /// Detected format.
    pub format: Format,
    /// Mesh upload size in bytes.
    pub bytes: u64,
    /// Vertices after repair.
    pub vertices: u64,
    /// Triangles after repair.
    pub triangles: u64,
    /// Surface area.
    pub area: f64,
    /// Bounding-box diagonal.
    pub bbox_diagonal: f64,
    /// Mean edge length.
    pub mean_edge_length: f64,
    /// Estimated output triangles, area / (√3/4 · L²).
    pub estimated_output_triangles: u64,
    /// External glTF buffers received, by uri.
    pub buffers: Vec<String>,
    /// What the builder repaired.
    pub repairs: RepairReport,
}

/// Where to download the result and what it is.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ResultView {
    /// The download URL (add `?format=` for another format).
    pub href: String,
    /// Stored format.
    pub format: Format,
    /// Size in that format.
    pub bytes: u64,
    /// Strong ETag of that file.
    pub etag: String,
    /// Output vertices.
    pub vertices: u64,
    /// Output triangles.
    pub triangles: u64,
}

/// A job as `GET /v1/jobs/{id}` returns it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobView {
    /// Job id.
    pub id: String,
    /// Status.
    pub status: JobStatus,
    /// The job's URL.
    pub href: String,
    /// Latest progress (null while queued).
    pub progress: Option<Progress>,
    /// Submission time.
    pub created_at: String,
    /// Start of the last run.
    pub started_at: Option<String>,
    /// End of the run.
    pub finished_at: Option<String>,
    /// When the job and its result expire (set once finished).
    pub expires_at: Option<String>,
    /// Whether the result was removed after expiry.
    pub expired: bool,
    /// Whether a cancel was requested and not yet acted on.
    pub cancel_requested: bool,
    /// Times a worker started the job (more than 1 after a restart).
    pub attempts: u32,
    /// Normalised parameters.
    pub params: Params,
    /// Input summary.
    pub input: InputView,
    /// Input and output statistics, once succeeded.
    pub stats: Option<JobStats>,
    /// The result, once succeeded.
    pub result: Option<ResultView>,
    /// Why the job failed.
    pub error: Option<Problem>,
}

/// The URL of a job.
pub fn job_href(id: &str) -> String {
    format!("/v1/jobs/{id}")
}

/// A strong ETag from a hex digest.
pub fn etag(sha256_hex: &str) -> String {
    format!("\"{sha256_hex}\"")
}

impl JobView {
    /// The view of a record.
    pub fn new(r: &JobRecord, cancel_requested: bool) -> Self {
        let i = &r.input;
        Self {
            id: r.id.clone(),
            status: r.status,
            href: job_href(&r.id),
            progress: r.progress,
            created_at: rfc3339(r.created_ms),
            started_at: r.started_ms.map(rfc3339),
            finished_at: r.finished_ms.map(rfc3339),
            expires_at: r.expires_ms.map(rfc3339),
            expired: r.result_expired,
            cancel_requested: cancel_requested && !r.status.is_finished(),
            attempts: r.attempts,
            params: r.params.clone(),
            input: InputView {
                file_name: i.file_name.clone(),
                format: i.format,
                bytes: i.bytes,
                vertices: i.vertices,
                triangles: i.triangles,
                area: i.geometry.area,
                bbox_diagonal: i.geometry.bbox_diagonal,
                mean_edge_length: i.geometry.mean_edge_length,
                estimated_output_triangles: i.estimated_output_triangles,
                buffers: i.buffers.clone(),
                repairs: i.repairs,
            },
            stats: r.stats.clone(),
            result: r.result.as_ref().map(|res| ResultView {
                href: format!("{}/result", job_href(&r.id)),
                format: res.format,
                bytes: res.bytes,
                etag: etag(&res.sha256),
                vertices: res.vertices,
                triangles: res.triangles,
            }),
            error: r.error.clone(),
        }
    }
}

/// A job in a list.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobSummary {
    /// Job id.
    pub id: String,
    /// Status.
    pub status: JobStatus,
    /// The job's URL.
    pub href: String,
    /// Latest progress.
    pub progress: Option<Progress>,
    /// Submission time.
    pub created_at: String,
    /// End of the run.
    pub finished_at: Option<String>,
    /// Expiry.
    pub expires_at: Option<String>,
    /// Input format.
    pub input_format: Format,
    /// Output format.
    pub output_format: Option<Format>,
}

impl JobSummary {
    /// The summary of a record.
    pub fn new(r: &JobRecord) -> Self {
        Self {
            id: r.id.clone(),
            status: r.status,
            href: job_href(&r.id),
            progress: r.progress,
            created_at: rfc3339(r.created_ms),
            finished_at: r.finished_ms.map(rfc3339),
            expires_at: r.expires_ms.map(rfc3339),
            input_format: r.input.format,
            output_format: r.params.output_format,
        }
    }
}

/// A page of `GET /v1/jobs`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobList {
    /// Jobs, newest first.
    pub jobs: Vec<JobSummary>,
    /// Pass as `cursor` for the next page; null on the last page.
    pub next_cursor: Option<String>,
}

/// `GET /healthz` and `GET /readyz`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Health {
    /// `ok`, `ready`, `shutting_down` or `storage_unavailable`.
    pub status: String,
    /// Why the service is not ready, when it is not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detail: Option<String>,
    /// Jobs waiting.
    pub queue_depth: usize,
    /// Queue capacity.
    pub queue_capacity: usize,
    /// Workers busy.
    pub workers_busy: usize,
    /// Worker count.
    pub workers: usize,
}

//! Errors at the HTTP edge, rendered once as RFC 9457 problem details
//! (`application/problem+json`): a stable `type` URI per kind, a `title`, the
//! `status`, a `detail` for this occurrence and, for caller mistakes, the
//! `field` at fault (a parameter name, `mesh`, a buffer `uri` or a header).
//! Library errors ([`JobError`]) are mapped here and nowhere else; details of
//! internal failures are logged, never sent.

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};

use crate::io::IoError;
use crate::mesh::BuildError;
use crate::pipeline::JobError;
use crate::remesh::RemeshError;

/// Media type of problem documents.
pub const PROBLEM_JSON: &str = "application/problem+json";

/// Every kind of problem the service reports, with its status and title.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    /// The request is malformed: bad multipart, missing `mesh` part, bad JSON.
    InvalidRequest,
    /// The upload did not arrive before the upload deadline.
    UploadTimeout,
    /// The body exceeds the size limit.
    BodyTooLarge,
    /// The input mesh has more triangles than allowed.
    MeshTooLarge,
    /// The mesh format is unknown.
    UnsupportedFormat,
    /// The mesh cannot be read (truncated, malformed, NaN, empty, ...).
    InvalidMesh,
    /// A parameter is unknown, mistyped or out of range.
    InvalidParameter,
    /// The estimated output exceeds the triangle limit.
    OutputTooLarge,
    /// An `Idempotency-Key` was reused with a different request.
    IdempotencyConflict,
    /// The queue is full.
    QueueFull,
    /// The service is shutting down.
    ShuttingDown,
    /// Every connection the server may hold is open and busy.
    TooManyConnections,
    /// No job has this id.
    JobNotFound,
    /// No route matches the path.
    NotFound,
    /// The route exists but not for this method.
    MethodNotAllowed,
    /// The job has no result (yet).
    ResultNotReady,
    /// The job is already finished and cannot be cancelled.
    JobFinished,
    /// The result expired and was removed.
    ResultExpired,
    /// The job passed its wall-time limit.
    JobTimeout,
    /// The job was interrupted (the process stopped or crashed while it ran)
    /// more often than the attempt limit allows.
    TooManyAttempts,
    /// API keys are configured and the request has none, or a bad one.
    Unauthorized,
    /// The key sent more requests than its rate limit allows.
    RateLimited,
    /// A per-key quota (jobs at once, bytes stored) would be passed.
    QuotaExceeded,
    /// The uploads in flight hold all of the server's upload slots or bytes.
    UploadsBusy,
    /// The data directory has too little free space for the upload.
    InsufficientStorage,
    /// The data directory cannot be written (or a file cannot be removed).
    StorageUnavailable,
    /// A bug or an unexpected failure on our side.
    Internal,
}

impl ProblemKind {
    /// The last segment of the `type` URI.
    pub fn slug(self) -> &'static str {
        match self {
            ProblemKind::InvalidRequest => "invalid-request",
            ProblemKind::UploadTimeout => "upload-timeout",
            ProblemKind::BodyTooLarge => "body-too-large",
            ProblemKind::MeshTooLarge => "mesh-too-large",
            ProblemKind::UnsupportedFormat => "unsupported-format",
            ProblemKind::InvalidMesh => "invalid-mesh",
            ProblemKind::InvalidParameter => "invalid-parameter",
            ProblemKind::OutputTooLarge => "output-too-large",
            ProblemKind::IdempotencyConflict => "idempotency-conflict",
            ProblemKind::QueueFull => "queue-full",
            ProblemKind::ShuttingDown => "shutting-down",
            ProblemKind::TooManyConnections => "too-many-connections",
            ProblemKind::JobNotFound => "job-not-found",
            ProblemKind::NotFound => "not-found",
            ProblemKind::MethodNotAllowed => "method-not-allowed",
            ProblemKind::ResultNotReady => "result-not-ready",
            ProblemKind::JobFinished => "job-finished",
            ProblemKind::ResultExpired => "result-expired",
            ProblemKind::JobTimeout => "job-timeout",
            ProblemKind::TooManyAttempts => "too-many-attempts",
            ProblemKind::Unauthorized => "unauthorized",
            ProblemKind::RateLimited => "rate-limited",
            ProblemKind::QuotaExceeded => "quota-exceeded",
            ProblemKind::UploadsBusy => "uploads-busy",
            ProblemKind::InsufficientStorage => "insufficient-storage",
            ProblemKind::StorageUnavailable => "storage-unavailable",
            ProblemKind::Internal => "internal",
        }
    }

    /// The HTTP status.
    pub fn status(self) -> StatusCode {
        match self {
            ProblemKind::InvalidRequest => StatusCode::BAD_REQUEST,
            ProblemKind::UploadTimeout => StatusCode::REQUEST_TIMEOUT,
            ProblemKind::BodyTooLarge | ProblemKind::MeshTooLarge => StatusCode::PAYLOAD_TOO_LARGE,
            ProblemKind::UnsupportedFormat => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ProblemKind::InvalidMesh
            | ProblemKind::InvalidParameter
            | ProblemKind::OutputTooLarge
            | ProblemKind::IdempotencyConflict
            | ProblemKind::JobTimeout
            | ProblemKind::TooManyAttempts => StatusCode::UNPROCESSABLE_ENTITY,
            ProblemKind::QueueFull
            | ProblemKind::ShuttingDown
            | ProblemKind::TooManyConnections
            | ProblemKind::UploadsBusy
            | ProblemKind::StorageUnavailable => StatusCode::SERVICE_UNAVAILABLE,
            ProblemKind::InsufficientStorage => StatusCode::INSUFFICIENT_STORAGE,
            ProblemKind::JobNotFound | ProblemKind::NotFound => StatusCode::NOT_FOUND,
            ProblemKind::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            ProblemKind::ResultNotReady | ProblemKind::JobFinished => StatusCode::CONFLICT,
            ProblemKind::ResultExpired => StatusCode::GONE,
            ProblemKind::Unauthorized => StatusCode::UNAUTHORIZED,
            ProblemKind::RateLimited | ProblemKind::QuotaExceeded => StatusCode::TOO_MANY_REQUESTS,
            ProblemKind::Internal => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The short, kind-wide title.
    pub fn title(self) -> &'static str {
        match self {
            ProblemKind::InvalidRequest => "Malformed request",
            ProblemKind::UploadTimeout => "Upload too slow",
            ProblemKind::BodyTooLarge => "Request body too large",
            ProblemKind::MeshTooLarge => "Input mesh too large",
            ProblemKind::UnsupportedFormat => "Unsupported mesh format",
            ProblemKind::InvalidMesh => "Invalid mesh",
            ProblemKind::InvalidParameter => "Invalid parameter",
            ProblemKind::OutputTooLarge => "Estimated output too large",
            ProblemKind::IdempotencyConflict => "Idempotency-Key reused with a different request",
            ProblemKind::QueueFull => "Job queue full",
            ProblemKind::ShuttingDown => "Service shutting down",
            ProblemKind::TooManyConnections => "Too many connections",
            ProblemKind::JobNotFound => "Job not found",
            ProblemKind::NotFound => "Not found",
            ProblemKind::MethodNotAllowed => "Method not allowed",
            ProblemKind::ResultNotReady => "Result not available",
            ProblemKind::JobFinished => "Job already finished",
            ProblemKind::ResultExpired => "Result expired",
            ProblemKind::JobTimeout => "Job time limit exceeded",
            ProblemKind::TooManyAttempts => "Job interrupted too often",
            ProblemKind::Unauthorized => "API key missing or not valid",
            ProblemKind::RateLimited => "Too many requests",
            ProblemKind::QuotaExceeded => "Quota exceeded",
            ProblemKind::UploadsBusy => "Too many uploads in flight",
            ProblemKind::InsufficientStorage => "Insufficient storage",
            ProblemKind::StorageUnavailable => "Storage unavailable",
            ProblemKind::Internal => "Internal error",
        }
    }
}

/// An RFC 9457 problem document.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Problem {
    /// A URI identifying the kind of problem (`urn:isoremesh:problem:<slug>`).
    #[serde(rename = "type")]
    pub kind: String,
    /// Short summary of the kind.
    pub title: String,
    /// The HTTP status code.
    pub status: u16,
    /// What went wrong in this occurrence.
    pub detail: String,
    /// The request field at fault: a parameter, `mesh`, a buffer uri or a header.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// Seconds after which a retry may succeed (also sent as `Retry-After`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retry_after: Option<u64>,
}

/// The longest `detail` a problem carries: messages quote what was sent
/// (a value, a name), and a client must not get its megabytes echoed back.
pub const MAX_DETAIL_BYTES: usize = 1024;
/// The longest `field`: a part name or a parameter name.
pub const MAX_FIELD_BYTES: usize = 256;

/// `text` cut to at most `max` bytes on a character boundary, with an
/// ellipsis and the full length when it was cut.
fn excerpt(text: String, max: usize) -> String {
    if text.len() <= max {
        return text;
    }
    let mut end = max.saturating_sub(40);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes in all)", &text[..end], text.len())
}

impl Problem {
    /// A problem of `kind` with the given detail.
    pub fn new(kind: ProblemKind, detail: impl Into<String>) -> Self {
        Self {
            kind: format!("urn:isoremesh:problem:{}", kind.slug()),
            title: kind.title().to_string(),
            status: kind.status().as_u16(),
            detail: excerpt(detail.into(), MAX_DETAIL_BYTES),
            field: None,
            retry_after: None,
        }
    }

    /// Names the field at fault.
    pub fn with_field(mut self, field: impl Into<String>) -> Self {
        self.field = Some(excerpt(field.into(), MAX_FIELD_BYTES));
        self
    }

    /// Adds a `Retry-After` in seconds.
    pub fn with_retry_after(mut self, secs: u64) -> Self {
        self.retry_after = Some(secs);
        self
    }

    /// Whether this problem is of `kind`.
    pub fn is(&self, kind: ProblemKind) -> bool {
        self.kind.ends_with(kind.slug()) && self.kind.len() == 22 + kind.slug().len()
    }

    /// An internal failure: logs `cause` and returns a problem that does not
    /// reveal it.
    pub fn internal(context: &str, cause: impl std::fmt::Display) -> Self {
        tracing::error!(%cause, "{context}");
        Problem::new(
            ProblemKind::Internal,
            format!("{context}; the cause was logged"),
        )
    }

    /// Maps a failure of reading, building or remeshing the input.
    pub fn from_job_error(e: &JobError) -> Self {
        match e {
            JobError::Io(e) => Self::from_io_error(e),
            JobError::Build(e) => match e {
                BuildError::TooLarge(_) => {
                    Problem::new(ProblemKind::MeshTooLarge, e.to_string()).with_field("mesh")
                }
                _ => Problem::new(ProblemKind::InvalidMesh, e.to_string()).with_field("mesh"),
            },
            JobError::Remesh(e) => match e {
                RemeshError::InvalidOption { field, message } => {
                    Problem::new(ProblemKind::InvalidParameter, format!("{field}: {message}"))
                        .with_field(*field)
                }
                RemeshError::EmptyInput => {
                    Problem::new(ProblemKind::InvalidMesh, e.to_string()).with_field("mesh")
                }
                RemeshError::TooManyFaces { .. } => {
                    Problem::new(ProblemKind::OutputTooLarge, e.to_string())
                        .with_field("target_edge_length")
                }
                RemeshError::Cancelled => Problem::new(ProblemKind::Internal, e.to_string()),
                RemeshError::Internal(_) => Problem::internal("the remesher failed", e),
            },
        }
    }

    /// Maps a format-layer error.
    pub fn from_io_error(e: &IoError) -> Self {
        match e {
            IoError::UnknownFormat { .. } => {
                Problem::new(ProblemKind::UnsupportedFormat, e.to_string()).with_field("mesh")
            }
            IoError::TooLarge { .. } => {
                Problem::new(ProblemKind::MeshTooLarge, e.to_string()).with_field("mesh")
            }
            IoError::ExternalBuffer { uri, .. } => {
                Problem::new(ProblemKind::InvalidMesh, e.to_string()).with_field(uri.clone())
            }
            _ => Problem::new(ProblemKind::InvalidMesh, e.to_string()).with_field("mesh"),
        }
    }
}

/// What a problem response carries for the access log (a response
/// extension): the kind and the field at fault.
#[derive(Clone, Debug)]
pub struct Logged {
    /// The problem's slug (`unauthorized`, `invalid-parameter`, …).
    pub slug: String,
    /// The field at fault, if any.
    pub field: Option<String>,
}

impl IntoResponse for Problem {
    fn into_response(self) -> Response {
        let logged = Logged {
            slug: self
                .kind
                .strip_prefix("urn:isoremesh:problem:")
                .unwrap_or(&self.kind)
                .to_string(),
            field: self.field.clone(),
        };
        let status = StatusCode::from_u16(self.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
        let retry = self.retry_after;
        let body = serde_json::to_vec(&self).unwrap_or_default();
        let mut resp = (status, body).into_response();
        let h = resp.headers_mut();
        h.insert(header::CONTENT_TYPE, HeaderValue::from_static(PROBLEM_JSON));
        if let Some(s) = retry {
            h.insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        resp.extensions_mut().insert(logged);
        resp
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_map_to_their_status_and_type() {
        let p = Problem::new(ProblemKind::QueueFull, "full").with_retry_after(3);
        assert_eq!(p.status, 503);
        assert_eq!(p.kind, "urn:isoremesh:problem:queue-full");
        assert!(p.is(ProblemKind::QueueFull));
        assert!(!p.is(ProblemKind::NotFound));
        let r = p.into_response();
        assert_eq!(r.status(), StatusCode::SERVICE_UNAVAILABLE);
        assert_eq!(r.headers()[header::RETRY_AFTER], "3");
        assert_eq!(r.headers()[header::CONTENT_TYPE], PROBLEM_JSON);
    }

    #[test]
    fn remesh_option_errors_name_their_field() {
        let e = JobError::Remesh(RemeshError::InvalidOption {
            field: "gradation",
            message: "must be positive".into(),
        });
        let p = Problem::from_job_error(&e);
        assert_eq!(p.status, 422);
        assert_eq!(p.field.as_deref(), Some("gradation"));
    }
}

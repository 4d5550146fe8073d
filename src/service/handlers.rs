//! One function per endpoint. Handlers translate HTTP into calls on the
//! [`super::server::Service`] and the pipeline and back; blocking work
//! (parsing, file I/O, re-encoding) goes to `spawn_blocking`, and every
//! failure leaves as a [`Problem`].

use std::collections::HashMap;
use std::sync::Arc;

use axum::body::Body;
use axum::extract::{Extension, Path, Query, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use sha2::{Digest, Sha256};

use super::auth::Caller;
use super::bundle;
use super::dto::{etag, job_href, Health, JobList, JobSummary, JobView};
use super::jobs::{now_ms, CancelReason, Idempotency, InputInfo, Job, JobRecord, JobStatus};
use super::params::{estimate_output, InputGeometry};
use super::problem::{Problem, ProblemKind};
use super::server::{AppState, Service};
use super::store::{is_job_id, StorageFault};
use super::upload::{read_upload, Upload};
use crate::io::{Format, ReadOptions};
use crate::params::Params;
use crate::pipeline::{self, LoadedInput};

/// The contract, served as is.
pub const OPENAPI_YAML: &str = include_str!("../../openapi.yaml");

/// Seconds a client should wait before polling an unfinished job again.
const POLL_RETRY_SECS: u64 = 1;
/// Seconds a client should wait after a 503.
const BUSY_RETRY_SECS: u64 = 5;

fn job_not_found(id: &str) -> Problem {
    Problem::new(
        ProblemKind::JobNotFound,
        format!("no job has the id {id:?}"),
    )
    .with_field("id")
}

/// The job `id` if the caller may see it. Another key's job answers as if
/// it did not exist, so that ids cannot be probed.
fn find(svc: &Service, id: &str, caller: &Caller) -> Result<Arc<Job>, Problem> {
    if !is_job_id(id) {
        return Err(job_not_found(id));
    }
    svc.jobs
        .get(id)
        .filter(|j| j.update(|r| caller.may_see(r.owner.as_deref())))
        .ok_or_else(|| job_not_found(id))
}

async fn blocking<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> Result<T, Problem> {
    let span = tracing::Span::current();
    tokio::task::spawn_blocking(move || span.in_scope(f))
        .await
        .map_err(|e| Problem::internal("a background task failed", e))
}

fn job_response(status: StatusCode, job: &Job, location: bool) -> Response {
    let rec = job.snapshot();
    let view = JobView::new(&rec, job.is_cancel_requested());
    let mut resp = (status, Json(view)).into_response();
    let h = resp.headers_mut();
    if !rec.status.is_finished() {
        h.insert(header::RETRY_AFTER, HeaderValue::from(POLL_RETRY_SECS));
    }
    if location {
        if let Ok(v) = HeaderValue::from_str(&job_href(&rec.id)) {
            h.insert(header::LOCATION, v);
        }
    }
    resp
}

/// What validation of an upload produced.
struct Checked {
    params: Params,
    input: InputInfo,
    /// The parsed input, for the worker.
    loaded: LoadedInput,
}

/// Parses the params and the mesh and checks the output estimate.
fn check_upload(svc: &Service, up: &Upload) -> Result<Checked, Problem> {
    let cfg = &svc.config;
    let mut params = up.params.clone();
    let options = params.job_options(cfg.threads_per_job(), cfg.max_output_triangles)?;
    let read = ReadOptions {
        external_buffers: up.buffers.iter().cloned().collect(),
        max_triangles: cfg.max_input_triangles,
    };
    let loaded = pipeline::load(&up.mesh, up.file_name.as_deref(), up.format_hint, &read)
        .map_err(|e| Problem::from_job_error(&e))?;
    if let Some(name) = unreferenced_part(&up.mesh, loaded.format, &read.external_buffers) {
        let detail = if matches!(loaded.format, Format::Gltf | Format::Obj) {
            format!(
                "the part {name:?} is not a file that the {} model names",
                loaded.format
            )
        } else {
            format!(
                "extra parts are companion files of a .gltf or an OBJ, but the mesh is {}; send only `mesh` and `params`",
                loaded.format
            )
        };
        return Err(Problem::new(ProblemKind::InvalidRequest, detail).with_field(name));
    }
    // The repaired surface, kept in the reference for the engine.
    let tm = loaded.surface();
    let geometry = InputGeometry {
        area: tm.area(),
        bbox_diagonal: tm.bbox_diagonal(),
        mean_edge_length: loaded.mean_edge_length(),
    };
    let est = estimate_output(&geometry, &options);
    if est.triangles > cfg.max_output_triangles {
        return Err(Problem::new(
            ProblemKind::OutputTooLarge,
            format!(
                "edges of length {:.6e} would give about {} triangles (area / (√3/4·L²)), more than the limit of {}; choose a larger {}",
                est.edge_length,
                crate::remesh::face_count_text(est.estimate),
                cfg.max_output_triangles,
                est.field
            ),
        )
        .with_field(est.field));
    }
    let format = *params.output_format.get_or_insert(loaded.format);
    if params.quality_attributes && !format.stores_attributes() {
        return Err(Problem::new(
            ProblemKind::InvalidParameter,
            format!(
                "quality_attributes: the output format {format} cannot carry them; choose output_format glb, gltf or ply"
            ),
        )
        .with_field("quality_attributes"));
    }
    Ok(Checked {
        params,
        input: InputInfo {
            file_name: up.file_name.clone(),
            format: loaded.format,
            bytes: up.mesh.len() as u64,
            vertices: loaded.mesh.vertex_count() as u64,
            triangles: loaded.mesh.face_count() as u64,
            geometry,
            estimated_output_triangles: est.triangles,
            buffers: up.buffers.iter().map(|(u, _)| u.clone()).collect(),
            repairs: loaded.repairs,
        },
        loaded,
    })
}

/// `POST /v1/jobs`: validate, store and queue a job.
pub async fn submit(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    req: Request,
) -> Result<Response, Problem> {
    if svc.is_shutting_down() {
        return Err(shutting_down());
    }
    let headers = req.headers().clone();
    let request_id = headers
        .get("x-request-id")
        .and_then(|v| v.to_str().ok())
        .map(str::to_string);
    let key = match headers.get("idempotency-key") {
        None => None,
        Some(v) => match v.to_str() {
            Ok(k) if !k.is_empty() && k.len() <= 255 => Some(k.to_string()),
            _ => {
                return Err(Problem::new(
                    ProblemKind::InvalidRequest,
                    "Idempotency-Key must be 1 to 255 visible ASCII characters",
                )
                .with_field("Idempotency-Key"))
            }
        },
    };
    let upload = read_upload(req, &svc.config, &svc.uploads, &svc.metrics).await?;
    let _gate = match &key {
        Some(_) => Some(svc.idempotency_gate.lock().await),
        None => None,
    };
    if let Some(k) = &key {
        if let Some((fingerprint, id)) = svc.jobs.by_key(caller.owner(), k) {
            if fingerprint != upload.fingerprint {
                return Err(Problem::new(
                    ProblemKind::IdempotencyConflict,
                    format!("the key {k:?} was used for job {id} with a different request"),
                )
                .with_field("Idempotency-Key"));
            }
            if let Some(job) = svc.jobs.get(&id) {
                let mut resp = job_response(StatusCode::OK, &job, true);
                resp.headers_mut()
                    .insert("idempotent-replayed", HeaderValue::from_static("true"));
                return Ok(resp);
            }
        }
    }
    let upload_bytes = upload.mesh.len() as u64
        + upload
            .buffers
            .iter()
            .map(|(_, b)| b.len() as u64)
            .sum::<u64>();
    let _admission = svc.auth.admit(
        &caller,
        upload_bytes,
        |owner| svc.jobs.usage(owner),
        &svc.metrics,
    )?;
    let permit = svc
        .parse_permits
        .acquire()
        .await
        .map_err(|e| Problem::internal("parse permits closed", e))?;
    let (checked, upload) = {
        let svc = Arc::clone(&svc);
        blocking(move || (check_upload(&svc, &upload), upload)).await?
    };
    drop(permit);
    let checked = checked?;
    let Some(slot) = svc.queue.try_reserve() else {
        if svc.is_shutting_down() {
            return Err(shutting_down());
        }
        svc.metrics.job_rejected();
        return Err(Problem::new(
            ProblemKind::QueueFull,
            format!(
                "all {} queue slots are taken; retry later",
                svc.queue.capacity()
            ),
        )
        .with_retry_after(BUSY_RETRY_SECS));
    };
    let id = uuid::Uuid::new_v4().to_string();
    let record = JobRecord {
        id: id.clone(),
        status: JobStatus::Queued,
        created_ms: now_ms(),
        started_ms: None,
        finished_ms: None,
        expires_ms: None,
        params: checked.params,
        input: checked.input,
        progress: None,
        stats: None,
        result: None,
        error: None,
        idempotency: key.map(|key| Idempotency {
            key,
            fingerprint: upload.fingerprint.clone(),
        }),
        request_id,
        attempts: 0,
        result_expired: false,
        owner: caller.owner().map(str::to_string),
        upload_bytes,
    };
    let job = Arc::new(Job::new(record.clone()));
    if let Some(prepared) = svc.prepared.hold(checked.loaded) {
        job.set_prepared(prepared);
    }
    {
        let svc = Arc::clone(&svc);
        blocking(move || {
            svc.store
                .check_writable(svc.config.min_free_bytes, upload_bytes)
                .map_err(storage_problem)?;
            svc.store
                .create_job(&record, &upload.mesh, &upload.buffers)
                .map_err(|e| storage_problem(StorageFault::from_io(e)))
        })
        .await??;
    }
    svc.jobs.insert(Arc::clone(&job));
    slot.commit(id.clone());
    svc.metrics.job_submitted();
    tracing::info!(job_id = %id, "job queued");
    Ok(job_response(StatusCode::ACCEPTED, &job, true))
}

/// A storage fault as the client's problem: 507 when space ran out, 503
/// when the directory cannot be written. Never a 500: the client did
/// nothing wrong, and a retry elsewhere or later may pass.
fn storage_problem(f: StorageFault) -> Problem {
    tracing::error!(error = %f, "data directory fault");
    match f {
        StorageFault::Full { .. } | StorageFault::OutOfSpace(_) => Problem::new(
            ProblemKind::InsufficientStorage,
            format!("the upload was not stored: {f}"),
        ),
        StorageFault::NotWritable(_) => Problem::new(
            ProblemKind::StorageUnavailable,
            "the upload was not stored: the data directory is not writable; the cause was logged",
        )
        .with_retry_after(BUSY_RETRY_SECS),
    }
}

fn shutting_down() -> Problem {
    Problem::new(
        ProblemKind::ShuttingDown,
        "the service is shutting down; retry against the next instance",
    )
    .with_retry_after(BUSY_RETRY_SECS)
}

/// `GET /v1/jobs/{id}`.
pub async fn get_job(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
) -> Result<Response, Problem> {
    let job = find(&svc, &id, &caller)?;
    Ok(job_response(StatusCode::OK, &job, false))
}

/// `POST /v1/jobs/{id}/cancel`: a queued job is cancelled at once (200); a
/// running one is asked to stop and stops within a fraction of a second (202).
pub async fn cancel(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
) -> Result<Response, Problem> {
    let job = find(&svc, &id, &caller)?;
    let now = now_ms();
    let ttl = svc.config.result_ttl_secs * 1000;
    let before = job.update(|r| {
        let s = r.status;
        if s == JobStatus::Queued {
            r.cancel(now, ttl);
        }
        s
    });
    match before {
        JobStatus::Queued => {
            svc.queue.remove(&id);
            drop(job.take_prepared());
            let s = Arc::clone(&svc);
            let j = Arc::clone(&job);
            blocking(move || s.persist(&j)).await?;
            tracing::info!(job_id = %id, "queued job cancelled");
            Ok(job_response(StatusCode::OK, &job, false))
        }
        JobStatus::Running => {
            job.request_cancel(CancelReason::User);
            tracing::info!(job_id = %id, "cancel requested");
            Ok(job_response(StatusCode::ACCEPTED, &job, false))
        }
        s => Err(Problem::new(
            ProblemKind::JobFinished,
            format!("the job is already {}", s.as_str()),
        )),
    }
}

/// `DELETE /v1/jobs/{id}`: cancels if needed and removes the job and its files.
pub async fn delete(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
) -> Result<Response, Problem> {
    let job = find(&svc, &id, &caller)?;
    job.request_cancel(CancelReason::User);
    job.mark_deleted();
    svc.queue.remove(&id);
    svc.jobs.remove(&id);
    let s = Arc::clone(&svc);
    let j = Arc::clone(&job);
    if blocking(move || s.remove(&j)).await?.is_err() {
        // Keep the job reachable, so that the client can retry the DELETE
        // instead of believing it gone while its files stay.
        svc.jobs.insert(job);
        return Err(Problem::new(
            ProblemKind::StorageUnavailable,
            "the job's files could not be removed; it is cancelled but not deleted: retry the DELETE",
        )
        .with_retry_after(BUSY_RETRY_SECS));
    }
    tracing::info!(job_id = %id, "job deleted");
    Ok(StatusCode::NO_CONTENT.into_response())
}

fn only_params(q: &HashMap<String, String>, allowed: &[&str]) -> Result<(), Problem> {
    match q.keys().find(|k| !allowed.contains(&k.as_str())) {
        Some(k) => Err(Problem::new(
            ProblemKind::InvalidParameter,
            format!("unknown query parameter; allowed: {}", allowed.join(", ")),
        )
        .with_field(k.clone())),
        None => Ok(()),
    }
}

fn bad_query(e: axum::extract::rejection::QueryRejection) -> Problem {
    Problem::new(
        ProblemKind::InvalidRequest,
        format!("bad query string: {e}"),
    )
}

/// The first extra part (in name order) that the model does not name as a
/// companion file, so that a misspelt part is refused rather than ignored.
fn unreferenced_part(
    mesh: &[u8],
    format: Format,
    parts: &HashMap<String, Vec<u8>>,
) -> Option<String> {
    let named = crate::io::companions::companion_names(mesh, format, parts);
    let mut names: Vec<&String> = parts.keys().collect();
    names.sort();
    names
        .into_iter()
        .find(|part| {
            !named
                .iter()
                .any(|c| crate::io::companions::is_named(part, &c.name))
        })
        .cloned()
}

/// `GET /v1/jobs/{id}/result[?format=...][&bundle=zip]`: the result file;
/// another format is re-encoded from the exact stored mesh. With
/// `bundle=zip`, a zip archive of the file and its companions (an OBJ's
/// `.mtl` and texture images).
pub async fn result(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
    query: Result<Query<HashMap<String, String>>, axum::extract::rejection::QueryRejection>,
    headers: HeaderMap,
) -> Result<Response, Problem> {
    let Query(q) = query.map_err(bad_query)?;
    only_params(&q, &["format", "bundle"])?;
    let job = find(&svc, &id, &caller)?;
    let rec = job.snapshot();
    let wanted = match q.get("format") {
        Some(f) => Some(f.parse::<Format>().map_err(|e| {
            Problem::new(ProblemKind::InvalidParameter, e.to_string()).with_field("format")
        })?),
        None => None,
    };
    let bundle = match q.get("bundle").map(String::as_str) {
        None | Some("none") => false,
        Some("zip") => true,
        Some(other) => {
            return Err(Problem::new(
                ProblemKind::InvalidParameter,
                format!("bundle must be zip or none, not {other:?}"),
            )
            .with_field("bundle"))
        }
    };
    let expired = || {
        Problem::new(
            ProblemKind::ResultExpired,
            "the result expired and was removed; submit the job again",
        )
    };
    if rec.status.is_finished()
        && (rec.result_expired || rec.expires_ms.is_some_and(|e| now_ms() >= e))
    {
        return Err(expired());
    }
    let stored = match (&rec.status, &rec.result) {
        (JobStatus::Succeeded, Some(r)) => r.clone(),
        (s, _) => {
            return Err(Problem::new(
                ProblemKind::ResultNotReady,
                format!(
                    "the job is {}; a result exists only once it succeeded",
                    s.as_str()
                ),
            ))
        }
    };
    let format = wanted.unwrap_or(stored.format);
    let stem = rec.result_stem();
    let not_found = move |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::NotFound => expired(),
        _ => Problem::internal("cannot read the result", e),
    };
    let s = Arc::clone(&svc);
    let rid = id.clone();
    let name = stem.clone();
    let (bytes, digest) = if format == stored.format && !bundle {
        let bytes = blocking(move || s.store.read_result(&rid, format))
            .await?
            .map_err(not_found)?;
        (bytes, stored.sha256.clone())
    } else {
        blocking(move || -> Result<(Vec<u8>, String), Problem> {
            let mesh = s.store.read_result_mesh(&rid).map_err(not_found)?;
            let mut files = pipeline::encode_files(&mesh, format, &Default::default(), &name)
                .map_err(|e| Problem::internal("cannot re-encode the result", e))?;
            if format == stored.format {
                // The stored file keeps what re-encoding would not (quality attributes).
                files[0].1 = s.store.read_result(&rid, format).map_err(not_found)?;
            }
            let bytes = if bundle {
                bundle::zip(&files).map_err(|e| Problem::internal("cannot pack the result", e))?
            } else {
                files.swap_remove(0).1
            };
            let digest = hex::encode(Sha256::digest(&bytes));
            Ok((bytes, digest))
        })
        .await??
    };
    let tag = etag(&digest);
    let (file_name, mime) = if bundle {
        (format!("{stem}.zip"), "application/zip")
    } else {
        (format!("{stem}.{}", format.extension()), format.mime())
    };
    let disposition = format!("attachment; filename=\"{file_name}\"");
    let not_modified = headers
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == tag || t.trim() == "*"));
    let mut resp = if not_modified {
        StatusCode::NOT_MODIFIED.into_response()
    } else {
        (StatusCode::OK, Body::from(bytes)).into_response()
    };
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(mime));
    if let Ok(v) = HeaderValue::from_str(&disposition) {
        h.insert(header::CONTENT_DISPOSITION, v);
    }
    if let Ok(v) = HeaderValue::from_str(&tag) {
        h.insert(header::ETAG, v);
    }
    Ok(resp)
}

/// Default and largest page size of `GET /v1/jobs`.
const DEFAULT_PAGE: usize = 50;
const MAX_PAGE: usize = 1000;

/// `GET /v1/jobs?status=&limit=&cursor=`: newest first.
pub async fn list(
    State(svc): State<AppState>,
    Extension(caller): Extension<Caller>,
    query: Result<Query<HashMap<String, String>>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Problem> {
    let Query(q) = query.map_err(bad_query)?;
    only_params(&q, &["status", "limit", "cursor"])?;
    let invalid = |field: &str, detail: String| {
        Problem::new(ProblemKind::InvalidParameter, detail).with_field(field)
    };
    let status = match q.get("status") {
        Some(s) => Some(JobStatus::parse(s).ok_or_else(|| {
            invalid(
                "status",
                format!("{s:?} is not one of queued, running, succeeded, failed, cancelled"),
            )
        })?),
        None => None,
    };
    let limit = match q.get("limit") {
        Some(l) => l
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=MAX_PAGE).contains(n))
            .ok_or_else(|| invalid("limit", format!("must be an integer from 1 to {MAX_PAGE}")))?,
        None => DEFAULT_PAGE,
    };
    let after = match q.get("cursor") {
        Some(c) => Some(
            parse_cursor(c)
                .ok_or_else(|| invalid("cursor", "not a cursor from a previous page".into()))?,
        ),
        None => None,
    };
    let mut recs: Vec<JobRecord> = svc
        .jobs
        .all()
        .iter()
        .map(|j| j.snapshot())
        .filter(|r| caller.may_see(r.owner.as_deref()))
        .filter(|r| status.is_none_or(|s| r.status == s))
        .filter(|r| {
            after
                .as_ref()
                .is_none_or(|(ms, id)| (r.created_ms, &r.id) < (*ms, id))
        })
        .collect();
    recs.sort_by(|a, b| (b.created_ms, &b.id).cmp(&(a.created_ms, &a.id)));
    let more = recs.len() > limit;
    recs.truncate(limit);
    let next_cursor = if more {
        recs.last().map(|r| format!("{}.{}", r.created_ms, r.id))
    } else {
        None
    };
    Ok(Json(JobList {
        jobs: recs.iter().map(JobSummary::new).collect(),
        next_cursor,
    })
    .into_response())
}

fn parse_cursor(c: &str) -> Option<(u64, String)> {
    let (ms, id) = c.split_once('.')?;
    is_job_id(id).then_some(())?;
    Some((ms.parse().ok()?, id.to_string()))
}

fn health(svc: &Service, status: &str) -> Health {
    let g = svc.gauges();
    Health {
        status: status.to_string(),
        detail: None,
        queue_depth: g.queue_depth,
        queue_capacity: g.queue_capacity,
        workers_busy: g.workers_busy,
        workers: g.workers,
    }
}

/// `GET /healthz`: the process is alive.
pub async fn healthz(State(svc): State<AppState>) -> Response {
    Json(health(&svc, "ok")).into_response()
}

/// `GET /readyz`: 200 while accepting jobs; 503 once shutting down, or
/// while the data directory is not writable or has less free space than
/// `--min-free-bytes`.
pub async fn readyz(State(svc): State<AppState>) -> Response {
    let unavailable = |status: &str, detail: Option<String>| {
        let mut h = health(&svc, status);
        h.detail = detail;
        (StatusCode::SERVICE_UNAVAILABLE, Json(h)).into_response()
    };
    if svc.is_shutting_down() {
        return unavailable("shutting_down", None);
    }
    let s = Arc::clone(&svc);
    match blocking(move || s.store.check_writable(s.config.min_free_bytes, 0)).await {
        Ok(Ok(())) => Json(health(&svc, "ready")).into_response(),
        Ok(Err(f)) => unavailable("storage_unavailable", Some(f.to_string())),
        Err(p) => p.into_response(),
    }
}

/// `GET /metrics` in the Prometheus text format.
pub async fn metrics(State(svc): State<AppState>) -> Response {
    let text = svc.metrics.render(&svc.gauges());
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        text,
    )
        .into_response()
}

/// `GET /openapi.yaml`.
pub async fn openapi() -> Response {
    ([(header::CONTENT_TYPE, "application/yaml")], OPENAPI_YAML).into_response()
}

/// Any path without a route.
pub async fn not_found(req: Request) -> Problem {
    Problem::new(
        ProblemKind::NotFound,
        format!("no route for {}", req.uri().path()),
    )
}

/// A route that exists, with the wrong method.
pub async fn method_not_allowed(req: Request) -> Problem {
    Problem::new(
        ProblemKind::MethodNotAllowed,
        format!("{} is not allowed on {}", req.method(), req.uri().path()),
    )
}

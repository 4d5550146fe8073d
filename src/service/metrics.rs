//! Counters and the job-duration histogram, rendered in the Prometheus text
//! exposition format (version 0.0.4). Gauges that describe current state
//! (queue depth, jobs by status, busy workers) are read at scrape time from
//! the queue and the registry, so they cannot drift.

use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};

/// Upper bounds (seconds) of the job-duration histogram buckets.
pub const DURATION_BUCKETS: [f64; 12] = [
    0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0,
];

/// Monotonic counters of the service.
#[derive(Debug, Default)]
pub struct Metrics {
    submitted: AtomicU64,
    rejected: AtomicU64,
    finished: [AtomicU64; 3],
    triangles_in: AtomicU64,
    triangles_out: AtomicU64,
    duration_buckets: [AtomicU64; DURATION_BUCKETS.len()],
    duration_count: AtomicU64,
    duration_sum_micros: AtomicU64,
    /// Runs that used the input as submit parsed it, and runs that parsed
    /// the stored upload.
    inputs: [AtomicU64; 2],
    /// Connections accepted, evicted while idle at the cap, and refused at
    /// the cap because all were busy.
    connections: [AtomicU64; 3],
    /// Connections open now (kept by the accept loop, which owns them).
    connections_open: AtomicU64,
    /// Requests refused by a key or upload limit, per [`Refusal`].
    refusals: [AtomicU64; Refusal::ALL.len()],
}

/// Why a request was refused by an access or resource limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// No key, or a bad one (401).
    Unauthorized = 0,
    /// The key's rate limit (429).
    RateLimited = 1,
    /// The key's jobs queued and running at once (429).
    ActiveJobs = 2,
    /// The key's stored bytes (429).
    StoredBytes = 3,
    /// Uploads in flight, globally (503).
    UploadsInFlight = 4,
    /// Bytes of uploads in flight, globally (503).
    UploadBytesInFlight = 5,
}

impl Refusal {
    /// Every refusal, in counter order.
    pub const ALL: [Refusal; 6] = [
        Refusal::Unauthorized,
        Refusal::RateLimited,
        Refusal::ActiveJobs,
        Refusal::StoredBytes,
        Refusal::UploadsInFlight,
        Refusal::UploadBytesInFlight,
    ];

    /// The `reason` label.
    pub fn label(self) -> &'static str {
        match self {
            Refusal::Unauthorized => "unauthorized",
            Refusal::RateLimited => "rate_limited",
            Refusal::ActiveJobs => "active_jobs",
            Refusal::StoredBytes => "stored_bytes",
            Refusal::UploadsInFlight => "uploads_in_flight",
            Refusal::UploadBytesInFlight => "upload_bytes_in_flight",
        }
    }
}

/// State read at scrape time.
#[derive(Clone, Copy, Debug)]
pub struct Gauges {
    /// Jobs waiting in the queue.
    pub queue_depth: usize,
    /// Queue capacity.
    pub queue_capacity: usize,
    /// Workers remeshing right now.
    pub workers_busy: usize,
    /// Worker count.
    pub workers: usize,
    /// Jobs per status, in [`super::jobs::JobStatus::ALL`] order.
    pub jobs: [u64; 5],
    /// Bytes of parsed inputs held for queued jobs.
    pub prepared_bytes: u64,
    /// Uploads being received or checked.
    pub uploads_in_flight: u64,
    /// Their bytes so far.
    pub upload_bytes_in_flight: u64,
}

/// How a run ended, for the finished counter.
#[derive(Clone, Copy, Debug)]
pub enum Outcome {
    /// With a result.
    Succeeded = 0,
    /// With a problem.
    Failed = 1,
    /// Cancelled while running.
    Cancelled = 2,
}

impl Metrics {
    /// Counts an accepted submission.
    pub fn job_submitted(&self) {
        self.submitted.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a submission turned away because the queue was full.
    pub fn job_rejected(&self) {
        self.rejected.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a run's input: `reused` when the worker took the input that
    /// submit parsed, otherwise it parsed the stored upload.
    pub fn input_loaded(&self, reused: bool) {
        self.inputs[usize::from(!reused)].fetch_add(1, Ordering::Relaxed);
    }

    /// Records a finished run of `seconds` with its triangle counts.
    pub fn job_finished(&self, outcome: Outcome, seconds: f64, tris_in: u64, tris_out: u64) {
        self.finished[outcome as usize].fetch_add(1, Ordering::Relaxed);
        self.triangles_in.fetch_add(tris_in, Ordering::Relaxed);
        self.triangles_out.fetch_add(tris_out, Ordering::Relaxed);
        for (i, &b) in DURATION_BUCKETS.iter().enumerate() {
            if seconds <= b {
                self.duration_buckets[i].fetch_add(1, Ordering::Relaxed);
            }
        }
        self.duration_count.fetch_add(1, Ordering::Relaxed);
        self.duration_sum_micros
            .fetch_add((seconds.max(0.0) * 1e6) as u64, Ordering::Relaxed);
    }

    /// Counts an accepted connection, now open.
    pub fn connection_opened(&self) {
        self.connections[0].fetch_add(1, Ordering::Relaxed);
        self.connections_open.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a connection that closed.
    pub fn connection_closed(&self) {
        self.connections_open.fetch_sub(1, Ordering::Relaxed);
    }

    /// Counts an idle connection closed to make room at the cap.
    pub fn connection_evicted(&self) {
        self.connections[1].fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a connection refused at the cap (every open one was busy).
    pub fn connection_refused(&self) {
        self.connections[2].fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a request refused by an access or resource limit.
    pub fn refused(&self, why: Refusal) {
        self.refusals[why as usize].fetch_add(1, Ordering::Relaxed);
    }

    /// The exposition text.
    pub fn render(&self, g: &Gauges) -> String {
        let mut s = String::new();
        let ld = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let mut metric = |name: &str, kind: &str, help: &str, lines: &[(String, String)]| {
            let _ = writeln!(s, "# HELP {name} {help}\n# TYPE {name} {kind}");
            for (labels, v) in lines {
                let _ = writeln!(s, "{name}{labels} {v}");
            }
        };
        let one = |v: String| [(String::new(), v)];
        // One line per `label="value"` pair, for a counter array.
        let labelled = |label: &str, values: &[&str], counters: &[AtomicU64]| -> Vec<_> {
            values
                .iter()
                .zip(counters)
                .map(|(v, n)| (format!("{{{label}=\"{v}\"}}"), ld(n).to_string()))
                .collect()
        };
        metric(
            "isoremesh_queue_depth",
            "gauge",
            "Jobs waiting for a worker.",
            &one(g.queue_depth.to_string()),
        );
        metric(
            "isoremesh_queue_capacity",
            "gauge",
            "Jobs that may wait for a worker.",
            &one(g.queue_capacity.to_string()),
        );
        metric(
            "isoremesh_workers",
            "gauge",
            "Worker threads.",
            &one(g.workers.to_string()),
        );
        metric(
            "isoremesh_workers_busy",
            "gauge",
            "Workers remeshing now.",
            &one(g.workers_busy.to_string()),
        );
        metric(
            "isoremesh_prepared_input_bytes",
            "gauge",
            "Bytes of parsed inputs held for queued jobs.",
            &one(g.prepared_bytes.to_string()),
        );
        metric(
            "isoremesh_connections_open",
            "gauge",
            "HTTP connections open now.",
            &one(ld(&self.connections_open).to_string()),
        );
        let connections = labelled(
            "outcome",
            &["accepted", "evicted", "refused"],
            &self.connections,
        );
        metric(
            "isoremesh_connections_total",
            "counter",
            "HTTP connections: accepted, closed while idle to make room at the connection cap, and refused at the cap because every open one was busy.",
            &connections,
        );
        let reasons = Refusal::ALL.map(Refusal::label);
        let refusals = labelled("reason", &reasons, &self.refusals);
        metric(
            "isoremesh_refusals_total",
            "counter",
            "Requests refused by an API key, rate, quota or upload limit.",
            &refusals,
        );
        metric(
            "isoremesh_uploads_in_flight",
            "gauge",
            "Uploads being received or checked now.",
            &one(g.uploads_in_flight.to_string()),
        );
        metric(
            "isoremesh_upload_bytes_in_flight",
            "gauge",
            "Bytes of the uploads being received or checked now.",
            &one(g.upload_bytes_in_flight.to_string()),
        );
        let inputs = labelled("how", &["reused", "parsed"], &self.inputs);
        metric(
            "isoremesh_job_inputs_total",
            "counter",
            "Job runs by how they got their input: reused from submit, or parsed from the stored upload.",
            &inputs,
        );
        let states: Vec<_> = super::jobs::JobStatus::ALL
            .iter()
            .zip(g.jobs)
            .map(|(st, n)| (format!("{{status=\"{}\"}}", st.as_str()), n.to_string()))
            .collect();
        metric("isoremesh_jobs", "gauge", "Known jobs by status.", &states);
        metric(
            "isoremesh_jobs_submitted_total",
            "counter",
            "Jobs accepted.",
            &one(ld(&self.submitted).to_string()),
        );
        metric(
            "isoremesh_jobs_rejected_total",
            "counter",
            "Submissions refused because the queue was full.",
            &one(ld(&self.rejected).to_string()),
        );
        let finished = labelled(
            "outcome",
            &["succeeded", "failed", "cancelled"],
            &self.finished,
        );
        metric(
            "isoremesh_jobs_finished_total",
            "counter",
            "Job runs finished, by outcome.",
            &finished,
        );
        metric(
            "isoremesh_triangles_in_total",
            "counter",
            "Input triangles of finished runs.",
            &one(ld(&self.triangles_in).to_string()),
        );
        metric(
            "isoremesh_triangles_out_total",
            "counter",
            "Output triangles of succeeded runs.",
            &one(ld(&self.triangles_out).to_string()),
        );
        let mut hist: Vec<_> = DURATION_BUCKETS
            .iter()
            .zip(&self.duration_buckets)
            .map(|(b, n)| (format!("_bucket{{le=\"{b}\"}}"), ld(n).to_string()))
            .collect();
        let count = ld(&self.duration_count);
        hist.push(("_bucket{le=\"+Inf\"}".into(), count.to_string()));
        hist.push((
            "_sum".into(),
            format!("{}", ld(&self.duration_sum_micros) as f64 / 1e6),
        ));
        hist.push(("_count".into(), count.to_string()));
        metric(
            "isoremesh_job_duration_seconds",
            "histogram",
            "Wall time of finished job runs.",
            &hist,
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_buckets_are_cumulative() {
        let m = Metrics::default();
        m.job_finished(Outcome::Succeeded, 0.3, 10, 20);
        m.job_finished(Outcome::Failed, 100.0, 5, 0);
        let text = m.render(&Gauges {
            queue_depth: 2,
            queue_capacity: 8,
            workers_busy: 1,
            workers: 2,
            jobs: [1, 2, 3, 4, 5],
            uploads_in_flight: 0,
            upload_bytes_in_flight: 0,
            prepared_bytes: 7,
        });
        assert!(text.contains("isoremesh_job_duration_seconds_bucket{le=\"0.25\"} 0"));
        assert!(text.contains("isoremesh_job_duration_seconds_bucket{le=\"0.5\"} 1"));
        assert!(text.contains("isoremesh_job_duration_seconds_bucket{le=\"300\"} 2"));
        assert!(text.contains("isoremesh_job_duration_seconds_bucket{le=\"+Inf\"} 2"));
        assert!(text.contains("isoremesh_job_duration_seconds_count 2"));
        assert!(text.contains("isoremesh_triangles_in_total 15"));
        assert!(text.contains("isoremesh_jobs{status=\"failed\"} 4"));
        assert!(text.contains("isoremesh_queue_depth 2"));
        assert!(text.contains("isoremesh_prepared_input_bytes 7"));
    }

    #[test]
    fn inputs_are_counted_by_how_they_were_loaded() {
        let m = Metrics::default();
        m.input_loaded(true);
        m.input_loaded(true);
        m.input_loaded(false);
        let text = m.render(&Gauges {
            queue_depth: 0,
            queue_capacity: 1,
            workers_busy: 0,
            workers: 1,
            jobs: [0; 5],
            uploads_in_flight: 0,
            upload_bytes_in_flight: 0,
            prepared_bytes: 0,
        });
        assert!(
            text.contains("isoremesh_job_inputs_total{how=\"reused\"} 2"),
            "{text}"
        );
        assert!(
            text.contains("isoremesh_job_inputs_total{how=\"parsed\"} 1"),
            "{text}"
        );
    }
}

//! Accepting and serving HTTP/1.1 connections under limits: a deadline for
//! each request head (which also bounds how long a kept-alive connection may
//! sit idle), a cap on open connections, and graceful shutdown.
//!
//! At the cap, a new connection evicts the oldest connection that has no
//! request in flight (an idle keep-alive connection, or one that never sent
//! a request); only when every connection is busy is the newcomer refused,
//! with a `503` problem written straight to the socket. A flood of idle
//! connections therefore cannot lock out a client that sends a request: the
//! flood's own connections are the ones evicted. The peer address of each
//! connection is handed to the handlers as axum's `ConnectInfo`.

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::future::Future;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::extract::ConnectInfo;
use axum::Router;
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio::sync::{watch, Notify};

use super::metrics::Metrics;
use super::problem::{Problem, ProblemKind};

/// The limits of [`serve_connections`].
#[derive(Clone, Copy, Debug)]
pub struct ConnectionLimits {
    /// Most connections open at once.
    pub max_connections: usize,
    /// Deadline for a request head, from the moment the server waits for one
    /// (a new connection, or a kept-alive one between requests).
    pub header_timeout: Duration,
}

/// One open connection, as the registry sees it.
struct Open {
    in_flight: Arc<AtomicUsize>,
    close: Arc<Notify>,
}

/// The open connections, oldest first (ids are handed out in order).
#[derive(Default)]
struct Registry {
    next_id: u64,
    open: BTreeMap<u64, Open>,
}

impl Registry {
    /// Registers a connection when there is room, making room by asking the
    /// oldest idle connection to close; `None` when every one is busy.
    fn admit(
        &mut self,
        max: usize,
        metrics: &Metrics,
    ) -> Option<(u64, Arc<AtomicUsize>, Arc<Notify>)> {
        if self.open.len() >= max {
            let idle = self
                .open
                .iter()
                .find(|(_, c)| c.in_flight.load(Ordering::SeqCst) == 0)
                .map(|(&id, _)| id)?;
            if let Some(c) = self.open.remove(&idle) {
                c.close.notify_one();
                metrics.connection_evicted();
            }
        }
        let id = self.next_id;
        self.next_id += 1;
        let in_flight = Arc::new(AtomicUsize::new(0));
        let close = Arc::new(Notify::new());
        self.open.insert(
            id,
            Open {
                in_flight: Arc::clone(&in_flight),
                close: Arc::clone(&close),
            },
        );
        Some((id, in_flight, close))
    }
}

/// Counts a request in flight on its connection while it lives.
struct InFlight(Arc<AtomicUsize>);

impl InFlight {
    fn new(counter: &Arc<AtomicUsize>) -> Self {
        counter.fetch_add(1, Ordering::SeqCst);
        Self(Arc::clone(counter))
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// The response to a connection refused at the cap.
fn refusal() -> Vec<u8> {
    let problem = Problem::new(
        ProblemKind::TooManyConnections,
        "the server holds its maximum of open connections, all busy; retry shortly",
    )
    .with_retry_after(1);
    let body = serde_json::to_string(&problem).unwrap_or_default();
    format!(
        "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/problem+json\r\n\
         retry-after: 1\r\nconnection: close\r\ncontent-length: {}\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

/// Serves `app` on `listener` until `shutdown` completes, then stops
/// accepting, lets in-flight requests finish (idle connections close at
/// once) for up to `grace`, and returns.
pub async fn serve_connections(
    listener: TcpListener,
    app: Router,
    limits: ConnectionLimits,
    metrics: Arc<Metrics>,
    shutdown: impl Future<Output = ()> + Send + 'static,
    grace: Duration,
) -> std::io::Result<()> {
    let registry = Arc::new(Mutex::new(Registry::default()));
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout)
        .keep_alive(true);
    tokio::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            () = &mut shutdown => break,
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                Err(e) => {
                    // Out of file descriptors or a connection reset before
                    // accept: wait a moment instead of spinning.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
        };
        let admitted = registry
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .admit(limits.max_connections, &metrics);
        let Some((id, in_flight, close)) = admitted else {
            metrics.connection_refused();
            tracing::warn!(peer = %peer, "connection refused: every connection is busy");
            tokio::spawn(async move {
                let mut stream = stream;
                let _ = tokio::time::timeout(Duration::from_secs(1), async {
                    let _ = stream.write_all(&refusal()).await;
                    let _ = stream.shutdown().await;
                    // Drain what the client sent until it closes: closing a
                    // socket with unread input resets it, and the client
                    // could lose the answer.
                    let mut sink = [0u8; 4096];
                    while matches!(stream.read(&mut sink).await, Ok(n) if n > 0) {}
                })
                .await;
            });
            continue;
        };
        metrics.connection_opened();
        let _ = stream.set_nodelay(true);
        let app = app.clone();
        let service = hyper::service::service_fn(move |mut req: hyper::Request<Incoming>| {
            let guard = InFlight::new(&in_flight);
            req.extensions_mut().insert(ConnectInfo(peer));
            let mut app = app.clone();
            async move {
                let response = tower_service::Service::call(&mut app, req).await;
                drop(guard);
                Ok::<_, Infallible>(response.unwrap_or_else(|e: Infallible| match e {}))
            }
        });
        let conn = http
            .serve_connection(TokioIo::new(stream), service)
            .with_upgrades();
        let mut stop = stop_rx.clone();
        let registry = Arc::clone(&registry);
        let metrics = Arc::clone(&metrics);
        tokio::spawn(async move {
            tokio::pin!(conn);
            let mut closing = false;
            loop {
                tokio::select! {
                    result = conn.as_mut() => {
                        if let Err(e) = result {
                            tracing::debug!(peer = %peer, error = %e, "connection ended with an error");
                        }
                        break;
                    }
                    () = close.notified(), if !closing => {
                        closing = true;
                        conn.as_mut().graceful_shutdown();
                    }
                    _ = stop.changed(), if !closing => {
                        closing = true;
                        conn.as_mut().graceful_shutdown();
                    }
                }
            }
            registry
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .open
                .remove(&id);
            metrics.connection_closed();
        });
    }
    drop(listener);
    let _ = stop_tx.send(true);
    let deadline = tokio::time::Instant::now() + grace;
    while !registry
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .open
        .is_empty()
        && tokio::time::Instant::now() < deadline
    {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn at_the_cap_the_oldest_idle_connection_is_evicted_and_busy_ones_never() {
        let mut r = Registry::default();
        let m = Metrics::default();
        let (a, a_busy, _) = r.admit(2, &m).unwrap();
        let (b, _, b_close) = r.admit(2, &m).unwrap();
        a_busy.fetch_add(1, Ordering::SeqCst);
        // Full: b is the oldest idle one.
        let (c, c_busy, _) = r.admit(2, &m).unwrap();
        assert!(r.open.contains_key(&a) && !r.open.contains_key(&b) && r.open.contains_key(&c));
        // b was told to close (a permit is stored for its waiter).
        assert!(futures_lite_ready(&b_close));
        c_busy.fetch_add(1, Ordering::SeqCst);
        // Every connection busy: refused.
        assert!(r.admit(2, &m).is_none());
        assert_eq!(r.open.len(), 2);
    }

    /// Whether a `notify_one` is pending on `n` (consumes it).
    fn futures_lite_ready(n: &Notify) -> bool {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap();
        rt.block_on(async {
            tokio::time::timeout(Duration::from_millis(10), n.notified())
                .await
                .is_ok()
        })
    }
}

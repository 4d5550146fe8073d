//! Connection limits over real sockets: a flood of idle connections cannot
//! lock out a client with a request, idle connections are closed at the
//! request-head deadline, and when every connection is busy the excess is
//! refused with a problem document.

mod service_support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use service_support::{config, Server};

fn addr(s: &Server) -> String {
    s.base.trim_start_matches("http://").to_string()
}

/// Sends a bare `GET path` on a new connection and returns the whole answer.
fn raw_get(addr: &str, path: &str) -> String {
    let mut c = TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let _ = write!(
        c,
        "GET {path} HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n"
    );
    let mut out = String::new();
    let _ = c.read_to_string(&mut out);
    out
}

fn metric(s: &Server, line_start: &str) -> u64 {
    let text = s.get("/metrics").text().unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix(line_start))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("{line_start} not in /metrics"))
}

#[test]
fn health_answers_while_a_flood_of_idle_connections_is_held() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_connections = 32;
    let s = Server::start(cfg);
    let a = addr(&s);
    // Ten times the cap, all held open without a byte sent.
    let flood: Vec<TcpStream> = (0..320).map(|_| TcpStream::connect(&a).unwrap()).collect();
    std::thread::sleep(Duration::from_millis(200));
    for _ in 0..5 {
        let t = Instant::now();
        let answer = raw_get(&a, "/healthz");
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    }
    assert!(metric(&s, "isoremesh_connections_total{outcome=\"evicted\"}") >= 288);
    assert!(metric(&s, "isoremesh_connections_open") <= 33);
    drop(flood);
}

#[test]
fn an_idle_connection_is_closed_at_the_header_deadline() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.header_timeout_secs = 1;
    let s = Server::start(cfg);
    let mut c = TcpStream::connect(addr(&s)).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    // Half a request line, then silence (slowloris).
    c.write_all(b"GET /heal").unwrap();
    let t = Instant::now();
    let mut buf = [0u8; 512];
    let n = c.read(&mut buf).unwrap_or(0);
    let waited = t.elapsed();
    assert!(
        waited >= Duration::from_millis(900) && waited < Duration::from_secs(5),
        "{waited:?}"
    );
    // Closed, possibly with a 408 first.
    let text = String::from_utf8_lossy(&buf[..n]);
    assert!(n == 0 || text.starts_with("HTTP/1.1 408"), "{text}");
    // A kept-alive connection that goes quiet after a request closes too.
    let mut k = TcpStream::connect(addr(&s)).unwrap();
    k.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    k.write_all(b"GET /healthz HTTP/1.1\r\nhost: x\r\n\r\n")
        .unwrap();
    let n = k.read(&mut buf).unwrap();
    assert!(String::from_utf8_lossy(&buf[..n]).starts_with("HTTP/1.1 200"));
    let t = Instant::now();
    let mut rest = Vec::new();
    let _ = k.read_to_end(&mut rest);
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
}

#[test]
fn when_every_connection_is_busy_the_excess_gets_a_503_problem() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_connections = 2;
    let s = Server::start(cfg);
    let a = addr(&s);
    // Two uploads that have sent their head and part of their body: each
    // connection has a request in flight.
    let busy: Vec<TcpStream> = (0..2)
        .map(|_| {
            let mut c = TcpStream::connect(&a).unwrap();
            write!(
                c,
                "POST /v1/jobs HTTP/1.1\r\nhost: x\r\ncontent-type: multipart/form-data; boundary=b\r\ncontent-length: 100000\r\n\r\n--b\r\n"
            )
            .unwrap();
            c
        })
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let answer = raw_get(&a, "/healthz");
    assert!(answer.starts_with("HTTP/1.1 503"), "{answer}");
    assert!(answer.contains("application/problem+json"), "{answer}");
    assert!(answer.contains("too-many-connections"), "{answer}");
    assert!(
        answer.to_ascii_lowercase().contains("retry-after: 1"),
        "{answer}"
    );
    drop(busy);
    // Once they are gone, the server answers again.
    let t = Instant::now();
    loop {
        let answer = raw_get(&a, "/healthz");
        if answer.starts_with("HTTP/1.1 200") {
            break;
        }
        assert!(t.elapsed() < Duration::from_secs(5), "{answer}");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(metric(&s, "isoremesh_connections_total{outcome=\"refused\"}") >= 1);
}

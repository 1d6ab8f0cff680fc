//! `cansim serve`: real socketcand clients on the simulated bus. python-can 4.6.1's own socketcand
//! interface and cantools (from build/pyenv, made by `make pyenv`) exchange frames with the
//! scenario's nodes and with each other (tests/python/socketcand_clients.py); malformed input gets
//! `< error ... >` without touching the bus; an address that cannot be served is a clear error.

mod common;

use std::net::TcpListener;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::{cansim, cansim_with_env, example, python, scratch, text, Raw, ServeProcess, WAIT};

/// The counts row of node `name` in the server's summary: sent, received, dropped, TXERR, RXERR.
fn row(out: &str, name: &str) -> Vec<u64> {
    let line = out
        .lines()
        .find(|l| l.split_whitespace().next() == Some(name) && l.ends_with("error-active"))
        .unwrap_or_else(|| panic!("no row for {name} in\n{out}"));
    line.split_whitespace()
        .skip(1)
        .take(5)
        .map(|n| n.parse().unwrap())
        .collect()
}

/// The bus log once it holds `needle` (the server writes it as it goes).
fn wait_for_log(path: &Path, needle: &str) -> String {
    let start = std::time::Instant::now();
    loop {
        let log = std::fs::read_to_string(path).unwrap_or_default();
        if log.contains(needle) {
            return log;
        }
        assert!(start.elapsed() < WAIT, "no {needle:?} in\n{log}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn python_can_clients_exchange_frames_with_the_scenario_and_each_other() {
    let dir = scratch("serve", "python-can");
    let log = dir.join("bus.log");
    let mut server = ServeProcess::start(&example("serve.toml"), &["--log", log.to_str().unwrap()]);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/socketcand_clients.py");
    let o = Command::new(python())
        .arg(&script)
        .arg(server.port.to_string())
        .arg(example("engine.dbc"))
        .output()
        .unwrap();
    let out = server.stop();
    assert!(
        o.status.success() && text(&o.stdout).ends_with("PASS\n"),
        "python-can:\n{}{}\nserver:\n{out}",
        text(&o.stdout),
        text(&o.stderr)
    );
    // Both clients joined and left; the scenario's nodes received the four client frames.
    assert_eq!(out.matches(" opened can0 at ").count(), 2, "{out}");
    assert_eq!(out.matches(" left the bus: ").count(), 2, "{out}");
    let (ecu, gateway) = (row(&out, "ecu"), row(&out, "gateway"));
    assert_eq!(
        ecu[1],
        4 + gateway[0],
        "ecu received: the clients' 4 and the gateway's\n{out}"
    );
    assert_eq!(gateway[1], 4 + ecu[0], "{out}");
    assert!(
        out.contains("bus: ") && out.contains(" 0 error frames"),
        "{out}"
    );
    let log = std::fs::read_to_string(&log).unwrap();
    for frame in ["123#010203", "1ABCDE01#", "7FF#DEADBEEF000102FF", "321#55"] {
        assert_eq!(
            log.matches(&format!(" can0 {frame}\n")).count(),
            1,
            "{frame}\n{log}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn malformed_input_gets_an_error_the_connection_stays_and_the_bus_is_untouched() {
    let dir = scratch("serve", "malformed");
    let log = dir.join("bus.log");
    let mut server = ServeProcess::start(&example("serve.toml"), &["--log", log.to_str().unwrap()]);
    let mut client = Raw::connect(server.port);
    for (message, expected) in [
        (
            "< send 123 1 11 >",
            "< error open the bus first (open can0) >",
        ),
        ("< open can1 x >", "< error usage: open BUS >"),
    ] {
        assert_eq!(client.ask(message), expected, "{message}");
    }
    assert_eq!(client.ask("< open can0 >"), "< ok >");
    assert_eq!(client.ask("< rawmode >"), "< ok >");
    for (message, expected) in [
        ("< bogus >", "unknown command 'bogus'"),
        ("< send 800 0 >", "identifier 800 is out of range 000..7FF"),
        (
            "< send 20000000 1 1 >",
            "identifier 20000000 is out of range",
        ),
        ("< send 123 2 11 >", "LEN 2 but 1 data bytes given"),
        ("< send 123 9 1 2 3 4 5 6 7 8 9 >", "LEN 9 is more than 8"),
        ("< subscribe 0 0 123 >", "'subscribe' is not served"),
        ("garbage", "text outside a message, from byte 0x67"),
    ] {
        let answer = client.ask_in_raw_mode(message);
        assert!(
            answer.starts_with("< error ") && answer.contains(expected),
            "{message}: {answer}"
        );
    }
    // Still connected and served.
    assert_eq!(client.ask_in_raw_mode("< echo >"), "< echo >");
    client.say("< send 124 1 aa >");
    // A second client sends one frame and vanishes in the middle of its next message.
    let mut second = Raw::connect(server.port);
    assert_eq!(second.ask("< open can0 >"), "< ok >");
    second.say("< send 125 1 bb >< send 126 2 11");
    drop(second);
    // The server goes on: a third client is greeted and served.
    let mut third = Raw::connect(server.port);
    assert_eq!(third.ask("< echo >"), "< echo >");
    // The bus goes on past the ecu's first frame (due at 1 ms) and carries both clients' frames
    // (in any order: the bus runs while the clients talk, so they may come after the ecu's).
    for needle in [" can0 0C0#", " can0 124#AA\n", " can0 125#BB\n"] {
        wait_for_log(&log, needle);
    }
    let out = server.stop();
    let log = std::fs::read_to_string(&log).unwrap();
    assert!(log.contains(" can0 124#AA\n"), "{log}");
    assert!(log.contains(" can0 125#BB\n"), "{log}");
    for refused in ["800#", "20000000#", "123#11\n", "126#"] {
        assert!(
            !log.contains(&format!(" can0 {refused}")),
            "{refused}: {log}"
        );
    }
    assert!(!log.contains("ERROR FRAME"), "{log}");
    assert!(out.contains(" 0 error frames"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_address_that_cannot_be_served_is_a_clear_error() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = taken.local_addr().unwrap().to_string();
    let serve = example("serve.toml");
    for (listen, expected) in [
        (address.as_str(), "Address already in use"),
        // TEST-NET-1 (RFC 5737): no interface of this machine has it.
        ("192.0.2.1:29536", "Cannot assign requested address"),
        (
            "no-such-host.invalid:1",
            "cannot listen on no-such-host.invalid:1",
        ),
    ] {
        let o = cansim(&["serve", &serve, "--listen", listen]);
        assert!(!o.status.success(), "{listen}");
        let stderr = text(&o.stderr);
        assert!(
            stderr.contains(&format!("cannot listen on {listen}")) && stderr.contains(expected),
            "{listen}: {stderr}"
        );
        assert!(text(&o.stdout).is_empty(), "{}", text(&o.stdout));
    }
}

#[test]
fn until_ends_the_run_with_its_summary_and_real_time_says_when_it_cannot_keep_up() {
    let serve_3ms = |extra: &[&str], env: &[(&str, &str)]| {
        let serve = example("serve.toml");
        let mut args = vec!["serve", &serve, "--listen", "127.0.0.1:0", "--until", "3ms"];
        args.extend(extra);
        let o = cansim_with_env(&args, env);
        assert!(o.status.success(), "{}", text(&o.stderr));
        text(&o.stdout)
    };
    let out = serve_3ms(&[], &[]);
    assert!(out.contains("simulated 3.000 ms with 0 clients"), "{out}");
    // The ecu's first EngineStatus is due at 1 ms.
    assert_eq!(row(&out, "ecu")[0], 1, "{out}");
    // The rust-hdl engine runs far below real time (docs/ENGINES.md: under 0.02x, so 3 ms take
    // more than the 100 ms the server allows before it says so): it says so once.
    let out = serve_3ms(&["--realtime"], &[("CAN_ENGINE", "rust-hdl")]);
    assert_eq!(
        out.matches("cannot keep up with real time").count(),
        1,
        "{out}"
    );
    assert!(out.contains("x real time)"), "{out}");
}

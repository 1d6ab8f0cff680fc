//! Helpers shared by the command-line tests (each test binary uses a subset of them).
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

/// Runs the `cansim` binary with `args`.
pub fn cansim(args: &[&str]) -> Output {
    cansim_with_env(args, &[])
}

/// Runs the `cansim` binary with `args` and the environment variables `env` set.
pub fn cansim_with_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_cansim"));
    command.args(args);
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().expect("cansim runs")
}

/// A fresh, empty directory for test `test` of suite `suite`.
pub fn scratch(suite: &str, test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cansim-{suite}-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Output bytes as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The path of `name` under the repository's `examples/`.
pub fn example(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// How long a test waits for the server.
pub const WAIT: Duration = Duration::from_secs(120);

/// The Python of the test environment.
pub fn python() -> PathBuf {
    let python = Path::new(env!("CARGO_MANIFEST_DIR")).join("../build/pyenv/bin/python");
    assert!(
        python.exists(),
        "python-can and cantools are not installed: run `make pyenv` (`make test` does)"
    );
    python
}

/// A running `cansim serve` and the lines it prints.
pub struct ServeProcess {
    child: Child,
    lines: Receiver<String>,
    /// Lines read by [`ServeProcess::wait_for`].
    seen: Vec<String>,
    /// The port it listens on.
    pub port: u16,
}

impl ServeProcess {
    /// Starts `cansim serve SCENARIO --listen 127.0.0.1:0 ARGS` and reads its port.
    pub fn start(scenario: &str, args: &[&str]) -> ServeProcess {
        let mut child = Command::new(env!("CARGO_BIN_EXE_cansim"))
            .args(["serve", scenario, "--listen", "127.0.0.1:0"])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("cansim runs");
        let stdout = child.stdout.take().unwrap();
        let (send, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        let first = lines
            .recv_timeout(WAIT)
            .expect("cansim serve says where it listens");
        let port = first
            .split("127.0.0.1:")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|port| port.parse().ok())
            .unwrap_or_else(|| panic!("no port in {first:?}"));
        ServeProcess {
            child,
            lines,
            seen: Vec::new(),
            port,
        }
    }

    /// Reads its lines until one contains `needle` (within `timeout`); whether one did.
    pub fn wait_for(&mut self, needle: &str, timeout: Duration) -> bool {
        let end = std::time::Instant::now() + timeout;
        while let Some(left) = end.checked_duration_since(std::time::Instant::now()) {
            let Ok(line) = self.lines.recv_timeout(left) else {
                return false;
            };
            let found = line.contains(needle);
            self.seen.push(line);
            if found {
                return true;
            }
        }
        false
    }

    /// Stops it with SIGTERM, as a service manager would; everything it printed after the port.
    pub fn stop(&mut self) -> String {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let exit = self.child.wait().unwrap();
        let mut out = std::mem::take(&mut self.seen);
        out.extend(self.lines.iter());
        let out = out.join("\n");
        assert!(exit.success(), "exit {exit:?}\n{out}");
        out
    }
}

impl Drop for ServeProcess {
    /// A test that fails leaves no server behind.
    fn drop(&mut self) {
        let _ = self.child.kill();
    }
}

/// A raw socketcand connection, read line by line as the answers come.
pub struct Raw(TcpStream);

impl Raw {
    pub fn connect(port: u16) -> Raw {
        let stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        stream.set_read_timeout(Some(WAIT)).unwrap();
        let mut raw = Raw(stream);
        assert_eq!(raw.answer(), "< hi >");
        raw
    }

    /// The next message from the server.
    pub fn answer(&mut self) -> String {
        let mut message = Vec::new();
        let mut byte = [0u8];
        while message.last() != Some(&b'>') {
            self.0.read_exact(&mut byte).expect("an answer");
            message.push(byte[0]);
        }
        String::from_utf8(message).unwrap()
    }

    pub fn ask(&mut self, message: &str) -> String {
        self.0.write_all(message.as_bytes()).unwrap();
        self.answer()
    }

    /// The answer to `message` in raw mode, where frames from the bus may come first (the bus
    /// runs while the client talks): those are skipped.
    pub fn ask_in_raw_mode(&mut self, message: &str) -> String {
        self.0.write_all(message.as_bytes()).unwrap();
        loop {
            let answer = self.answer();
            if !answer.starts_with("< frame ") {
                return answer;
            }
        }
    }

    pub fn say(&mut self, message: &str) {
        self.0.write_all(message.as_bytes()).unwrap();
    }
}

impl Raw {
    /// Opens bus `can0` in raw mode.
    pub fn raw_mode(port: u16) -> Raw {
        let mut raw = Raw::connect(port);
        assert_eq!(raw.ask("< open can0 >"), "< ok >");
        assert_eq!(raw.ask("< rawmode >"), "< ok >");
        raw
    }

    /// Sends a data frame with a standard identifier.
    pub fn send_frame(&mut self, id: u16, data: &[u8]) {
        let bytes: Vec<String> = data.iter().map(|b| format!("{b:X}")).collect();
        self.say(&format!(
            "< send {id:03X} {} {} >",
            data.len(),
            bytes.join(" ")
        ));
    }

    /// The data of the next frame on `id` (other frames are skipped).
    pub fn frame_on(&mut self, id: u16) -> Vec<u8> {
        let wanted = format!("< frame {id:03X} ");
        loop {
            let message = self.answer();
            let Some(rest) = message.strip_prefix(&wanted) else {
                continue;
            };
            let hex = rest
                .trim_end_matches('>')
                .split_whitespace()
                .nth(1)
                .unwrap_or("");
            return (0..hex.len() / 2)
                .map(|k| u8::from_str_radix(&hex[2 * k..2 * k + 2], 16).unwrap())
                .collect();
        }
    }
}

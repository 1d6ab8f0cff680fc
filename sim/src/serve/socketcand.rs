//! The socketcand protocol in raw mode, as linux-can/socketcand's `doc/protocol.md` describes it:
//! ASCII messages `< … >` over TCP. The server greets with `< hi >`; the client opens a bus
//! (`< open can0 >`, answered `< ok >`) and switches to raw mode (`< rawmode >`, `< ok >`); from
//! then on every frame on the bus reaches it as `< frame ID SECONDS.MICROS DATA >` (a remote frame
//! as `< rtr ID SECONDS.MICROS DLC >`), and it sends with `< send ID LEN B0 B1 … >` or
//! `< sendrtr ID DLC >`. `< echo >` is answered with itself.
//!
//! Identifiers are hexadecimal: 3 digits (up to 7FF) for a standard identifier, 8 (up to
//! 1FFFFFFF) for an extended one, as socketcand writes them and python-can sends them. Data bytes
//! are hexadecimal, one or two digits each (python-can writes `1 f1`); in a received frame they
//! are one run of two digits per byte (`< frame 123 0.001000 01F1 >`; none: `< frame 123
//! 0.001000  >`, the double space kept, which is what python-can parses).

use golden::frame::{Frame, Id, MAX_DATA_LEN};

use crate::engine::time::seconds_micros;

/// The server's greeting.
pub const GREETING: &str = "< hi >";
/// The answer to `open` and `rawmode`.
pub const OK: &str = "< ok >";
/// The answer to `echo`.
pub const ECHO: &str = "< echo >";
/// Longest bus name `open` takes (the protocol's limit).
pub const MAX_BUS_NAME: usize = 16;
/// Longest message taken: `< send 1FFFFFFF 8 FF FF FF FF FF FF FF FF >` has 42 characters; what
/// runs on much longer without its `>` is not a message.
pub const MAX_MESSAGE: usize = 256;
/// Digits of a standard and of an extended identifier.
const STANDARD_DIGITS: usize = 3;
const EXTENDED_DIGITS: usize = 8;
/// Commands of socketcand's BCM, control and ISO-TP modes, which this server does not offer.
const OTHER_MODES: [&str; 12] = [
    "add",
    "update",
    "delete",
    "filter",
    "muxfilter",
    "subscribe",
    "unsubscribe",
    "controlmode",
    "statistics",
    "isotpmode",
    "isotpconf",
    "sendpdu",
];

/// What a client asks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Request {
    /// `< open BUS >`.
    Open(String),
    /// `< rawmode >`.
    RawMode,
    /// `< bcmmode >` (frames stop reaching the client).
    BcmMode,
    /// `< echo >`.
    Echo,
    /// `< send … >` or `< sendrtr … >`.
    Send(Frame),
}

/// Reads one message (`< … >`, the brackets included).
pub fn parse(message: &str) -> Result<Request, String> {
    let inner = message
        .strip_prefix('<')
        .and_then(|m| m.strip_suffix('>'))
        .ok_or_else(|| format!("'{message}' is not a message '< ... >'"))?;
    let words: Vec<&str> = inner.split_whitespace().collect();
    let Some((&command, args)) = words.split_first() else {
        return Err("empty message".to_string());
    };
    let no_arguments = |request: Request| {
        if args.is_empty() {
            Ok(request)
        } else {
            Err(format!("'{command}' takes no arguments"))
        }
    };
    match command {
        "open" => match args {
            [bus] if bus.len() <= MAX_BUS_NAME => Ok(Request::Open(bus.to_string())),
            [bus] => Err(format!(
                "bus name '{bus}' is longer than {MAX_BUS_NAME} characters"
            )),
            _ => Err("usage: open BUS".to_string()),
        },
        "rawmode" => no_arguments(Request::RawMode),
        "bcmmode" => no_arguments(Request::BcmMode),
        "echo" => no_arguments(Request::Echo),
        "send" => send(args).map(Request::Send),
        "sendrtr" => send_remote(args).map(Request::Send),
        other if OTHER_MODES.contains(&other) => Err(format!(
            "'{other}' is not served: this server speaks raw mode (open, rawmode, send, sendrtr, \
             echo)"
        )),
        other => Err(format!("unknown command '{other}'")),
    }
}

/// `send ID LEN B0 B1 …`.
fn send(args: &[&str]) -> Result<Frame, String> {
    let [id, len, bytes @ ..] = args else {
        return Err("usage: send ID LEN B0 B1 ...".to_string());
    };
    let id = identifier(id)?;
    let len = length(len)?;
    if bytes.len() != len {
        return Err(format!("LEN {len} but {} data bytes given", bytes.len()));
    }
    let data = bytes
        .iter()
        .map(|b| byte(b))
        .collect::<Result<Vec<u8>, String>>()?;
    Frame::data(id, &data).map_err(|e| e.to_string())
}

/// `sendrtr ID DLC`.
fn send_remote(args: &[&str]) -> Result<Frame, String> {
    let [id, dlc] = args else {
        return Err("usage: sendrtr ID DLC".to_string());
    };
    let dlc = length(dlc)?;
    Frame::remote(identifier(id)?, dlc as u8).map_err(|e| e.to_string())
}

/// A standard (3 hex digits) or extended (8) identifier.
fn identifier(text: &str) -> Result<Id, String> {
    let value = u32::from_str_radix(text, 16)
        .ok()
        .filter(|_| text.chars().all(|c| c.is_ascii_hexdigit()))
        .ok_or_else(|| format!("identifier '{text}' is not hexadecimal"))?;
    let out_of_range = |range: &str| format!("identifier {text} is out of range {range}");
    match text.len() {
        1..=STANDARD_DIGITS => {
            Id::standard(value as u16).map_err(|_| out_of_range("000..7FF (standard)"))
        }
        EXTENDED_DIGITS => Id::extended(value).map_err(|_| out_of_range("00000000..1FFFFFFF")),
        _ => Err(format!(
            "identifier '{text}' must have {STANDARD_DIGITS} hex digits (standard) or \
             {EXTENDED_DIGITS} (extended)"
        )),
    }
}

/// A data length of 0 to 8 (python-can writes it in hex, which is the same digit).
fn length(text: &str) -> Result<usize, String> {
    match u8::from_str_radix(text, 16) {
        Ok(n) if usize::from(n) <= MAX_DATA_LEN => Ok(usize::from(n)),
        Ok(_) => Err(format!("LEN {text} is more than {MAX_DATA_LEN}")),
        Err(_) => Err(format!("LEN '{text}' is not a number")),
    }
}

/// A data byte: one or two hex digits.
fn byte(text: &str) -> Result<u8, String> {
    if !(1..=2).contains(&text.len()) {
        return Err(format!("data byte '{text}' must be one or two hex digits"));
    }
    u8::from_str_radix(text, 16).map_err(|_| format!("data byte '{text}' is not hexadecimal"))
}

/// A frame received at simulated time `at_fs`, as the client gets it.
pub fn frame_message(frame: &Frame, at_fs: u64) -> String {
    let id = if frame.id().is_extended() {
        format!("{:08X}", frame.id().raw())
    } else {
        format!("{:03X}", frame.id().raw())
    };
    let time = seconds_micros(at_fs);
    if frame.is_remote() {
        return format!("< rtr {id} {time} {} >", frame.dlc());
    }
    let data: String = frame
        .data_bytes()
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect();
    format!("< frame {id} {time} {data} >")
}

/// An error message for the client.
pub fn error_message(what: &str) -> String {
    // `<` and `>` would end the message early.
    let what: String = what
        .chars()
        .map(|c| if c == '<' || c == '>' { '\'' } else { c })
        .collect();
    format!("< error {what} >")
}

/// Cuts the bytes a client sends into messages.
#[derive(Default)]
pub struct Splitter {
    partial: Vec<u8>,
    /// Inside a message that ran too long: skip to its `>`.
    skipping: bool,
    /// In text outside a message (reported once): skip to the next `<`.
    garbage: bool,
}

impl Splitter {
    /// Takes `bytes`; the complete messages in them (with what is wrong with the rest).
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<String, String>> {
        let mut out = Vec::new();
        for &b in bytes {
            if self.skipping {
                self.skipping = b != b'>';
                continue;
            }
            if self.partial.is_empty() {
                match b {
                    b'<' => {
                        self.partial.push(b);
                        self.garbage = false;
                    }
                    b if b.is_ascii_whitespace() => {}
                    _ if self.garbage => {}
                    other => {
                        self.garbage = true;
                        out.push(Err(format!(
                            "text outside a message, from byte 0x{other:02X} to the next <"
                        )));
                    }
                }
                continue;
            }
            self.partial.push(b);
            if b == b'>' {
                let message = std::mem::take(&mut self.partial);
                out.push(
                    String::from_utf8(message)
                        .ok()
                        .filter(|m| m.is_ascii())
                        .ok_or_else(|| "a message that is not ASCII".to_string()),
                );
            } else if self.partial.len() >= MAX_MESSAGE {
                self.partial.clear();
                self.skipping = true;
                out.push(Err(format!("a message longer than {MAX_MESSAGE} bytes")));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::time::{FS_PER_S, FS_PER_US};

    fn frame(text: &str) -> Frame {
        crate::scenario::candump::parse_frame(text).unwrap()
    }

    #[test]
    fn requests_as_python_can_and_the_protocol_text_write_them() {
        assert_eq!(parse("< open can0 >"), Ok(Request::Open("can0".into())));
        assert_eq!(parse("< rawmode >"), Ok(Request::RawMode));
        assert_eq!(parse("<echo>"), Ok(Request::Echo));
        // The protocol text's examples, and python-can's lower-case single digits.
        assert_eq!(parse("< send 123 0 >"), Ok(Request::Send(frame("123#"))));
        assert_eq!(
            parse("< send 1AAAAAAA 2 1 F1 >"),
            Ok(Request::Send(frame("1AAAAAAA#01F1")))
        );
        assert_eq!(
            parse("< send 7FF 8 1 2 3 4 5 6 7 ff >"),
            Ok(Request::Send(frame("7FF#01020304050607FF")))
        );
        assert_eq!(
            parse("< sendrtr 1AAAAAAA 2 >"),
            Ok(Request::Send(frame("1AAAAAAA#R2")))
        );
    }

    #[test]
    fn malformed_requests_say_what_is_wrong() {
        for (message, expected) in [
            ("< send 800 0 >", "identifier 800 is out of range 000..7FF"),
            ("< send 20000000 0 >", "identifier 20000000 is out of range"),
            ("< send 1234 0 >", "must have 3 hex digits (standard) or 8"),
            ("< send 12G 0 >", "identifier '12G' is not hexadecimal"),
            ("< send 123 2 11 >", "LEN 2 but 1 data bytes given"),
            ("< send 123 9 1 2 3 4 5 6 7 8 9 >", "LEN 9 is more than 8"),
            (
                "< send 123 1 100 >",
                "data byte '100' must be one or two hex digits",
            ),
            ("< send 123 1 zz >", "data byte 'zz' is not hexadecimal"),
            ("< send >", "usage: send ID LEN"),
            ("< add 1 0 123 0 >", "'add' is not served"),
            ("< hello >", "unknown command 'hello'"),
            ("< >", "empty message"),
            ("< open abcdefghijklmnopq >", "longer than 16 characters"),
            ("< rawmode now >", "'rawmode' takes no arguments"),
        ] {
            let error = parse(message).unwrap_err();
            assert!(error.contains(expected), "{message}: {error}");
        }
    }

    #[test]
    fn frames_reach_the_client_in_the_format_python_can_parses() {
        let at = 2 * FS_PER_S + 1_234 * FS_PER_US + 999;
        assert_eq!(
            frame_message(&frame("123#01F1"), at),
            "< frame 123 2.001234 01F1 >"
        );
        assert_eq!(
            frame_message(&frame("00000123#"), 0),
            "< frame 00000123 0.000000  >"
        );
        assert_eq!(
            frame_message(&frame("7FF#R3"), FS_PER_US),
            "< rtr 7FF 0.000001 3 >"
        );
        assert_eq!(error_message("a <b>"), "< error a 'b' >");
    }

    #[test]
    fn the_splitter_finds_messages_across_reads_and_reports_garbage() {
        let mut splitter = Splitter::default();
        assert!(splitter.push(b"< open ca").is_empty());
        assert_eq!(
            splitter.push(b"n0 >\n< rawmode ><echo>xyz"),
            vec![
                Ok("< open can0 >".to_string()),
                Ok("< rawmode >".to_string()),
                Ok("<echo>".to_string()),
                Err("text outside a message, from byte 0x78 to the next <".to_string()),
            ]
        );
        let long = vec![b'a'; 300];
        let mut bytes = b"<".to_vec();
        bytes.extend(&long);
        bytes.extend(b"> < echo >");
        let results = splitter.push(&bytes);
        assert_eq!(results.len(), 2, "{results:?}");
        assert!(results[0].as_ref().unwrap_err().contains("longer than 256"));
        assert_eq!(results[1], Ok("< echo >".to_string()));
        assert_eq!(
            splitter.push(b"< \xff >"),
            vec![Err("a message that is not ASCII".to_string())]
        );
    }
}

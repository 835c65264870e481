//! The Horus driver against the virtual board on a pseudo-terminal: the host sequence byte for byte
//! (issue 6, acceptance 2) and the faults (acceptance 3).
#![cfg(unix)]

use acquire::line::Recorder;
use acquire::virtual_horus::{Faults, VirtualBoard};
use acquire::{HorusOptions, HorusTurntable, Turntable, TurntableError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn options() -> HorusOptions {
    HorusOptions {
        greeting_timeout: Duration::from_millis(1500),
        reply_timeout: Duration::from_millis(400),
        motor_settle: Duration::ZERO,
        ..HorusOptions::default()
    }
}

fn open(board: &VirtualBoard) -> Box<dyn serialport::SerialPort> {
    serialport::new(&board.port, 115_200).timeout(Duration::from_millis(100)).open().unwrap()
}

#[test]
fn a_four_step_two_laser_session_sends_the_reference_host_sequence() {
    let board = VirtualBoard::start(Faults::default()).unwrap();
    let sent = Arc::new(Mutex::new(Vec::new()));
    let link = Recorder { inner: open(&board), sent: sent.clone() };
    let mut t = HorusTurntable::connect(link, &board.port, options()).unwrap();
    // Scan setup, four 90° steps with both lasers, finish — as PROTOCOLS.md gives the host sequence.
    t.laser(0, false).unwrap();
    t.laser(1, false).unwrap();
    t.motor(true).unwrap();
    t.set_zero().unwrap();
    t.set_speed(200.0).unwrap();
    t.set_acceleration(200.0).unwrap();
    for step in 0..4 {
        t.move_to(step as f64 * 90.0).unwrap();
        for laser in 0..2 {
            t.laser(laser, true).unwrap();
            assert!(board.snapshot().lasers[laser], "laser {laser} is on while the frame is captured");
            t.laser(laser, false).unwrap();
        }
    }
    // Feed and acceleration are sent only on change.
    t.set_speed(200.0).unwrap();
    t.set_acceleration(200.0).unwrap();
    t.laser(0, false).unwrap();
    t.laser(1, false).unwrap();
    t.motor(false).unwrap();
    let mut expected = vec![0x18u8];
    expected.extend_from_slice(b"\r\n");
    let mut lines = vec!["G1F1", "G50", "M70T1", "M70T2", "M17", "G50", "G1F200", "$120=200"];
    let steps: Vec<String> = (0..4).map(|s| format!("G1X{}", s * 90)).collect();
    for s in &steps {
        lines.extend([s.as_str(), "M71T1", "M70T1", "M71T2", "M70T2"]);
    }
    lines.extend(["M70T1", "M70T2", "M18"]);
    for l in lines {
        expected.extend_from_slice(l.as_bytes());
        expected.extend_from_slice(b"\r\n");
    }
    let got = sent.lock().unwrap().clone();
    assert_eq!(String::from_utf8_lossy(&got), String::from_utf8_lossy(&expected));
    let s = board.snapshot();
    assert_eq!((s.angle_deg, s.motor, s.lasers), (270.0, false, [false; 4]));
}

#[test]
fn a_wrong_greeting_is_named() {
    let board =
        VirtualBoard::start(Faults { greeting: "Grbl 1.1f ['$' for help]".into(), ..Faults::default() }).unwrap();
    let e = HorusTurntable::connect(open(&board), &board.port, options()).err().unwrap();
    assert!(matches!(e, TurntableError::NotHorus(_)), "{e}");
    assert!(e.to_string().contains("not Horus firmware (check board and baud rate)"), "{e}");
    let board =
        VirtualBoard::start(Faults { greeting: "Horus 0.1 ['$' for help]".into(), ..Faults::default() }).unwrap();
    let e = HorusTurntable::connect(open(&board), &board.port, options()).err().unwrap();
    assert!(matches!(e, TurntableError::OldFirmware(_)), "{e}");
}

#[test]
fn error_replies_carry_the_firmwares_text() {
    // Commands 1 and 2 are the opening G1F1 and G50.
    let board =
        VirtualBoard::start(Faults { error: vec![(3, "Modal group violation".into())], ..Faults::default() }).unwrap();
    let mut t = HorusTurntable::connect(open(&board), &board.port, options()).unwrap();
    let e = t.move_to(10.0).unwrap_err();
    assert_eq!(e, TurntableError::Firmware { command: "G1X10".into(), text: "Modal group violation".into() });
    t.move_to(10.0).unwrap();
}

#[test]
fn a_garbled_reply_is_retried_then_typed() {
    let board = VirtualBoard::start(Faults { garble: vec![3, 5, 6], ..Faults::default() }).unwrap();
    let mut t = HorusTurntable::connect(open(&board), &board.port, options()).unwrap();
    // Command 3 garbled, its retry (4) fine.
    t.move_to(5.0).unwrap();
    // Commands 5 and 6 both garbled: a typed error after two tries.
    let e = t.move_to(6.0).unwrap_err();
    assert!(matches!(&e, TurntableError::Garbled { command, tries: 2, .. } if command == "G1X6"), "{e}");
    assert_eq!(board.snapshot().angle_deg, 6.0);
}

#[test]
fn a_dropped_reply_is_resynchronised_and_retried() {
    let board = VirtualBoard::start(Faults { drop_reply: vec![3], ..Faults::default() }).unwrap();
    let mut t = HorusTurntable::connect(open(&board), &board.port, options()).unwrap();
    t.set_speed(50.0).unwrap(); // command 3: no reply; soft reset, the feed restored, then sent again
    t.move_to(30.0).unwrap();
    let s = board.snapshot();
    assert_eq!((s.angle_deg, s.feed), (30.0, Some(50.0)));
}

#[test]
fn an_unplugged_board_is_named_as_such() {
    let board = VirtualBoard::start(Faults { unplug_after: Some(4), ..Faults::default() }).unwrap();
    let mut t = HorusTurntable::connect(open(&board), &board.port, options()).unwrap();
    t.move_to(1.0).unwrap();
    t.move_to(2.0).unwrap();
    let mut last = None;
    for k in 0..4 {
        match t.move_to(3.0 + k as f64) {
            Err(e @ TurntableError::Unplugged { .. }) => {
                last = Some(e);
                break;
            }
            Err(e) => last = Some(e),
            Ok(()) => panic!("the board answered after it was unplugged"),
        }
    }
    let e = last.unwrap();
    assert!(matches!(e, TurntableError::Unplugged { .. }), "{e}");
    assert!(e.to_string().contains("unplugged"), "{e}");
}

/// Issue 19, defect 6: NaN, infinite and absurd angles and speeds are refused before anything is
/// sent, so the board is never left turning toward 1e30° and answers the next command at once.
#[test]
fn values_no_board_should_be_sent_are_refused_before_sending() {
    let board = VirtualBoard::start(Faults::default()).unwrap();
    let sent = Arc::new(Mutex::new(Vec::new()));
    let link = Recorder { inner: open(&board), sent: sent.clone() };
    let mut t = HorusTurntable::connect(link, &board.port, options()).unwrap();
    let before = sent.lock().unwrap().len();
    for angle in [f64::NAN, f64::INFINITY, -f64::INFINITY, 1e30, -36_001.0] {
        assert!(matches!(t.move_to(angle), Err(TurntableError::OutOfRange { .. })), "{angle}");
    }
    for speed in [0.0, -5.0, 1e-9, f64::NAN, f64::INFINITY, 1e6] {
        let e = t.set_speed(speed).unwrap_err();
        assert!(e.to_string().starts_with("the speed (degrees per second)"), "{speed}: {e}");
    }
    assert_eq!(sent.lock().unwrap().len(), before, "nothing was sent");
    t.move_to(10.0).unwrap();
}

//! The recording CSV reader of the `ema` CLI ([`parse_recording`], what `ema identify FILE`,
//! `ema discover` and `ema firmware-trace --from` read with) on arbitrary bytes, then, for an
//! accepted recording, `ema identify`'s checks and conditioning
//! ([`condition_recording_checked`] under the standard profile). Every input gives a value, never
//! a panic. An accepted recording holds `MIN_ROWS..=MAX_ROWS` rows of finite numbers at strictly
//! increasing times spanning at most `MAX_DURATION_S` (and, with a temperature column, a
//! temperature per row within `MIN_TEMPERATURE_C..=MAX_TEMPERATURE_C`), and reads back unchanged from what
//! [`write_csv`] makes of it. Its alignment with the standard profile and the command check
//! (`recording::align`) and the first samples of its resampling to 10 kHz (`recording::resample`)
//! give a value too, the resampled samples finite.
#![no_main]

use std::path::Path;

use ema_cli::identify::condition_recording_checked;
use ema_cli::recording::read::{parse_file, ReadOptions};
use ema_cli::recording::{align, resample};
use ema_cli::recording::{
    parse_recording, write_csv, MAX_COMMENT_LINES, MAX_DURATION_S, MAX_LINE_BYTES, MAX_ROWS, MAX_TEMPERATURE_C,
    MIN_ROWS, MIN_TEMPERATURE_C,
};
use ema_monitor::Profile;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.csv");
    let rec = match parse_recording(data, path) {
        Ok(rec) => rec,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let n = rec.len();
    assert!((MIN_ROWS..=MAX_ROWS).contains(&n));
    assert!(rec.comments.len() <= MAX_COMMENT_LINES);
    for column in [&rec.command_rad, &rec.position_rad, &rec.ia_a, &rec.ib_a, &rec.ic_a] {
        assert_eq!(column.len(), n);
        assert!(column.iter().all(|v| v.is_finite()));
    }
    assert_eq!(rec.row_line.len(), n);
    if let Some(t) = &rec.temperature_c {
        assert_eq!(t.len(), n);
        assert!(t.iter().all(|v| (MIN_TEMPERATURE_C..=MAX_TEMPERATURE_C).contains(v)));
    }
    assert!(rec.time_s.windows(2).all(|w| w[1] > w[0]));
    assert!(rec.time_s[n - 1] - rec.time_s[0] <= MAX_DURATION_S);
    // Written back and read again: the same recording (a comment is written as `# TEXT`, two
    // bytes longer than the shortest line that can hold it, so the longest ones are left out).
    if rec.comments.iter().all(|c| c.len() + 2 <= MAX_LINE_BYTES) {
        let mut csv = Vec::new();
        write_csv(&mut csv, &rec).expect("writes to memory");
        let back = parse_recording(&csv[..], path).expect("a written recording reads back");
        assert_eq!((&back.comments, &back.time_s, &back.command_rad), (&rec.comments, &rec.time_s, &rec.command_rad));
        assert_eq!(
            (&back.position_rad, &back.ia_a, &back.ib_a, &back.ic_a),
            (&rec.position_rad, &rec.ia_a, &rec.ib_a, &rec.ic_a)
        );
        assert_eq!(back.temperature_c, rec.temperature_c);
    }
    let parsed = parse_file(data, path, &ReadOptions::default()).expect("the same bytes parse again");
    let column = ("command_rad", 2);
    if let Ok(start) = align::find_start(&rec, &parsed.grid, &Profile::STANDARD, false, path, column) {
        assert!(start.is_finite());
        let _ = align::check_command(&rec, &parsed.grid, &Profile::STANDARD, start, 1e-4, path, column);
        let out = resample::resample(&[&rec.ia_a[..]], &parsed.grid, start, 1e-4, 16);
        assert!(out[0].iter().all(|v| v.is_finite()));
    }
    if let Ok((trace, summary)) = condition_recording_checked(&rec, path, &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD) {
        assert!(trace.is_finished() && trace.current_a().all(|i| i.is_finite()));
        assert_eq!(summary.frames as usize, n);
    }
});

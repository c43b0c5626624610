//! Host tests of the health record and store: encoding, history, save/load/reset, a power cut at
//! every byte of a save (at every position in the page cycle), every single corrupted byte, wear.

use super::store::WINDOW_SLOTS;
use super::*;
use crate::faults::FaultMode;
use crate::faults::FaultVector;
use crate::health::{Abstain, HealthReport, Status};
use crate::params::EmaParams;

/// The tests' flash: 4 pages of 2 KiB (two records per page, so saves cycle the pages quickly).
pub(super) type Flash = RamFlash<4, 2048>;
pub(super) const RANGE: core::ops::Range<u32> = 0..Flash::CAPACITY as u32;

pub(super) fn report(k: [f32; 8]) -> HealthReport {
    HealthReport::new(FaultVector(k), &EmaParams::NOMINAL, 0.01, 100, 10, None)
}

/// A record after `flights` flights of slowly growing friction and backlash.
pub(super) fn record_after(flights: u32) -> HealthRecord {
    let mut r = HealthRecord::new();
    for f in 0..flights {
        let x = 0.01 * f as f32;
        r.new_flight(&report([x, 0.5 * x, 0.0, 0.02, 0.0, 0.01, 0.5, 0.5 + 0.1 * x]), f % 5 == 0);
    }
    r.set_evidence([0.5 * flights as f32, -1.0, 0.25, 0.0, 3.0], flights);
    r
}

pub(super) fn store(flash: Flash) -> HealthStore<Flash> {
    HealthStore::new(flash, RANGE).expect("valid range")
}

/// A flash holding the saves of `record_after(1..=n)`.
pub(super) fn flash_with(n: u32) -> Flash {
    let mut s = store(Flash::new());
    for i in 1..=n {
        s.save(&record_after(i)).expect("save");
    }
    s.into_flash()
}

/// `loaded` is `expected`, bit for bit (`None`: nothing stored).
pub(super) fn is(loaded: &Result<Option<HealthRecord>, StoreError>, expected: Option<&HealthRecord>) -> bool {
    match (loaded, expected) {
        (Ok(Some(a)), Some(b)) => a.same_bits(b),
        (Ok(None), None) => true,
        _ => false,
    }
}

// ---- record ------------------------------------------------------------------------------------

#[test]
fn record_round_trips_bit_exactly() {
    let r = record_after(23);
    let mut buf = [0u8; HealthRecord::ENCODED_LEN];
    assert_eq!(r.encode(&mut buf), Ok(HealthRecord::ENCODED_LEN));
    let back = HealthRecord::decode(&buf).unwrap();
    assert!(back.same_bits(&r));
    assert!(back.sigma().iter().all(|s| s.is_nan()), "sigma unknown until set");
    assert_eq!(HealthRecord::ENCODED_LEN, 856);
    assert_eq!(buf[0], RECORD_VERSION);
}

#[test]
fn a_version_1_record_reads_with_its_history_and_no_identity() {
    let identity = RecordIdentity { params: EmaParams::NOMINAL.identity(), unit_serial: 42 };
    let mut r = HealthRecord::for_unit(identity);
    for f in 0..9 {
        r.new_flight(&report([0.02 * f as f32, 0.0, 0.0, 0.01, 0.0, 0.0, 0.5, 0.5]), f == 0);
    }
    let mut buf = [0u8; HealthRecord::ENCODED_LEN];
    r.encode(&mut buf).unwrap();
    assert_eq!(HealthRecord::decode(&buf).unwrap().identity(), identity);
    // version 1 is the same layout without the identity and commissioning at the end (752 bytes)
    let mut v1 = [0u8; 752];
    v1.copy_from_slice(&buf[..752]);
    v1[0] = 1;
    let old = HealthRecord::decode(&v1).unwrap();
    assert_eq!(old.identity(), RecordIdentity::UNKNOWN);
    assert_eq!((old.flights(), old.faults(), old.status()), (r.flights(), r.faults(), r.status()));
    assert!(FaultMode::ALL.iter().all(|&m| old.history(m) == r.history(m)));
    // each version has its own length
    assert_eq!(HealthRecord::decode(&buf[..752]), Err(RecordError::Length));
    let mut long_v1 = buf;
    long_v1[0] = 1;
    assert_eq!(HealthRecord::decode(&long_v1), Err(RecordError::Length));
    assert_eq!(HealthRecord::decode(&[]), Err(RecordError::Length));
}

#[test]
fn every_commissioning_state_round_trips_and_a_bad_one_is_refused() {
    let baseline = UnitBaseline {
        z: core::array::from_fn(|i| 0.25 * i as f32 - 1.0),
        sigma_z: core::array::from_fn(|i| 0.5 + 0.01 * i as f32),
        resolved: core::array::from_fn(|i| i % 3 != 1),
    };
    let states = [
        Commissioning::Off,
        Commissioning::Collecting { planned: 3, kept: 2 },
        Commissioning::Commissioned(baseline),
        Commissioning::Refused(CommissioningRefusal::OutOfTolerance { param: 7, z: 5.5 }),
        Commissioning::Refused(CommissioningRefusal::NotHealthy(Status::Degraded)),
        Commissioning::Refused(CommissioningRefusal::Failed),
    ];
    for state in states {
        let mut r = record_after(4);
        r.set_commissioning(state);
        let mut buf = [0u8; HealthRecord::ENCODED_LEN];
        r.encode(&mut buf).unwrap();
        let back = HealthRecord::decode(&buf).unwrap();
        assert_eq!(back.commissioning(), state);
        assert!(back.same_bits(&r));
        assert_eq!(back.baseline().is_some(), matches!(state, Commissioning::Commissioned(_)));
    }
    let mut r = record_after(1);
    r.set_commissioning(Commissioning::Collecting { planned: 2, kept: 1 });
    let mut buf = [0u8; HealthRecord::ENCODED_LEN];
    r.encode(&mut buf).unwrap();
    for (at, value) in [(762, 9u8), (761, 2), (762, 3)] {
        let mut bad = buf;
        bad[at] = value;
        if at == 762 && value == 3 {
            bad[763] = 11; // no twelfth unit parameter
        }
        assert_eq!(HealthRecord::decode(&bad), Err(RecordError::Commissioning), "byte {at} = {value}");
    }
}

#[test]
fn the_parameters_identity_tells_one_bit_of_one_field() {
    let n = EmaParams::NOMINAL;
    assert_eq!(n.identity(), EmaParams::NOMINAL.identity());
    for field in crate::params::FIELDS.iter() {
        let mut p = n;
        field.set(&mut p, f32::from_bits(field.get(&n).to_bits() ^ 1));
        assert_ne!(p.identity(), n.identity(), "{}", field.name);
    }
}

#[test]
fn the_archive_keeps_a_record_beside_the_current_one() {
    let mut s = store(Flash::new());
    assert_eq!(s.load_archive(), Ok(None));
    let old = record_after(7);
    s.save(&old).unwrap();
    s.archive(&old).unwrap();
    let new = HealthRecord::for_unit(RecordIdentity { params: 1, unit_serial: 2 });
    s.save(&new).unwrap();
    // many saves later (pages recycled), both are still there
    for _ in 0..20 {
        s.save(&new).unwrap();
    }
    let mut s = store(s.into_flash());
    assert!(is(&s.load(), Some(&new)));
    assert!(is(&s.load_archive(), Some(&old)));
}

#[test]
fn record_refuses_other_versions_and_bad_fields() {
    let mut buf = [0u8; HealthRecord::ENCODED_LEN];
    record_after(3).encode(&mut buf).unwrap();
    let mut bad = buf;
    bad[0] = RECORD_VERSION + 1;
    assert_eq!(HealthRecord::decode(&bad), Err(RecordError::Version(RECORD_VERSION + 1)));
    let mut bad = buf;
    bad[1] = 10;
    assert_eq!(HealthRecord::decode(&bad), Err(RecordError::Status(10)));
    let mut bad = buf;
    bad[100] = HISTORY_LEN as u8 + 1;
    assert_eq!(HealthRecord::decode(&bad), Err(RecordError::History));
    assert_eq!(HealthRecord::decode(&buf[..10]), Err(RecordError::Length));
    assert_eq!(record_after(1).encode(&mut [0u8; 10]), Err(RecordError::BufferTooSmall));
}

#[test]
fn new_flight_counts_flights_and_keeps_the_last_history() {
    let r = record_after(40);
    assert_eq!(r.flights(), 40);
    assert_eq!(r.flights_since_cold(), 4, "flight 36 (f = 35) was the last cold one");
    let h = r.history(FaultMode::Friction);
    assert_eq!(h.len(), HISTORY_LEN);
    assert_eq!(h.get(0).unwrap().flight, 40 - HISTORY_LEN as u32 + 1);
    assert_eq!(h.latest().unwrap().flight, 40);
    assert!((h.latest().unwrap().severity - 0.39).abs() < 1e-6);
    let flights: Vec<u32> = h.iter().map(|e| e.flight).collect();
    assert_eq!(flights, (25..=40).collect::<Vec<_>>());
    assert!(r.has_prior());
    assert_eq!(r.pooled_flights(), 40);
    assert!(!HealthRecord::new().has_prior());
    assert_eq!(HealthRecord::new().status(), None);
}

#[test]
fn every_status_has_its_own_code_and_reads_back() {
    use crate::persist::record::{status_code, status_of_code};
    let all = [
        Status::Healthy,
        Status::Degraded,
        Status::Failing,
        Status::Inconclusive(Abstain::PoorFit),
        Status::Inconclusive(Abstain::PartialCoverage),
        Status::Inconclusive(Abstain::RateMismatch),
        Status::Inconclusive(Abstain::UnitMismatch),
        Status::Inconclusive(Abstain::Commissioning),
        Status::Inconclusive(Abstain::NothingAssessable),
        Status::SensorFault,
    ];
    for (i, &s) in all.iter().enumerate() {
        assert!(all[..i].iter().all(|&t| status_code(t) != status_code(s)), "{s:?}");
        assert_eq!(status_of_code(status_code(s)), Ok(Some(s)));
    }
}

#[test]
fn an_abstention_is_recorded_but_joins_no_history() {
    let mut r = record_after(2);
    let inconclusive = report([0.3; 8]).abstaining(Status::Inconclusive(Abstain::PoorFit));
    r.new_flight(&inconclusive, false);
    assert_eq!(r.flights(), 3);
    assert_eq!(r.status(), Some(Status::Inconclusive(Abstain::PoorFit)));
    assert_eq!(r.history(FaultMode::Backlash).len(), 2);
    assert!(!r.has_prior());
    let mut buf = [0u8; HealthRecord::ENCODED_LEN];
    r.encode(&mut buf).unwrap();
    assert!(HealthRecord::decode(&buf).unwrap().same_bits(&r));
}

// ---- store -------------------------------------------------------------------------------------

#[test]
fn store_saves_loads_and_resets() {
    let mut s = store(Flash::new());
    assert_eq!(s.load(), Ok(None), "a fresh range holds nothing");
    for i in 1..=9 {
        let r = record_after(i);
        s.save(&r).unwrap();
        assert!(is(&s.load(), Some(&r)));
    }
    // a power cycle: a new store over the same flash
    let mut s = store(s.into_flash());
    assert!(is(&s.load(), Some(&record_after(9))));
    s.reset().unwrap();
    assert_eq!(s.load(), Ok(None), "maintenance reset");
    s.save(&record_after(1)).unwrap();
    assert!(is(&s.load(), Some(&record_after(1))));
}

#[test]
fn store_refuses_a_bad_range() {
    assert!(HealthStore::new(Flash::new(), 0..2048).is_err(), "one page");
    assert!(HealthStore::new(Flash::new(), 100..4196).is_err(), "not on page boundaries");
    assert!(HealthStore::new(RamFlash::<4, 512>::new(), 0..2048).is_err(), "pages smaller than a record");
}

#[test]
fn store_reports_a_record_of_another_version() {
    let mut s = store(Flash::new());
    s.save(&record_after(2)).unwrap();
    let mut flash = s.into_flash();
    // rewrite the stored copy's version byte would break its CRC; store a foreign record instead
    let mut foreign = [0u8; HealthRecord::ENCODED_LEN];
    record_after(2).encode(&mut foreign).unwrap();
    foreign[0] = RECORD_VERSION + 1;
    {
        use sequential_storage::cache::Cache;
        use sequential_storage::map::{MapConfig, MapStorage};
        let config = MapConfig::try_new(RANGE).unwrap();
        let mut map = MapStorage::<u8, _, _>::new(Blocking(&mut flash), config, Cache::new_uncached());
        let mut buf = [0u8; 1024];
        block_on(map.store_item(&mut buf, &store::RECORD_KEY, &&foreign[..])).unwrap().unwrap();
    }
    let mut s = store(flash);
    assert_eq!(s.load(), Err(StoreError::Record(RecordError::Version(RECORD_VERSION + 1))));
}

#[test]
fn a_dead_flash_is_an_error_value() {
    let mut flash = flash_with(1);
    flash.cut_power_after(0);
    let mut s = store(flash);
    assert_eq!(s.save(&record_after(2)), Err(StoreError::Flash(FlashFault::Other)));
    assert_eq!(s.reset(), Err(StoreError::Flash(FlashFault::Other)));
    // reads still work on the fake; the old record is intact
    assert!(is(&s.load(), Some(&record_after(1))));
}

/// Bytes a save of `record_after(n + 1)` writes and erases on a flash holding saves 1..=n.
fn save_cost(n: u32) -> u32 {
    let mut s = store(flash_with(n));
    let before = {
        let f = s.into_flash();
        let t = f.touched_bytes();
        s = store(f);
        t
    };
    s.save(&record_after(n + 1)).unwrap();
    s.into_flash().touched_bytes() - before
}

/// A power cut at every byte of a save, with the store at each position of its page cycle
/// (`n` = 0..=9 earlier saves: first save, a page's second record, a page change with its erase,
/// the wrap-around to page 0): after power comes back the load gives the old record or the new
/// one, never anything else, and the next save and load work.
#[test]
fn power_cut_at_every_byte_of_a_save_keeps_a_record() {
    let mut cuts = 0u32;
    let mut new_after_cut = 0u32;
    for n in 0..=9u32 {
        let base = flash_with(n);
        let old = (n > 0).then(|| record_after(n));
        let new = record_after(n + 1);
        let cost = save_cost(n);
        assert!(cost > HealthRecord::ENCODED_LEN as u32, "a save writes at least the record");
        for cut in 0..cost {
            let mut flash = base.clone();
            flash.cut_power_after(cut);
            let mut s = store(flash);
            assert!(s.save(&new).is_err(), "n {n}, cut {cut}: a cut save fails");
            let mut flash = s.into_flash();
            assert!(flash.is_off());
            flash.power_on();
            let mut s = store(flash);
            let loaded = s.load();
            if is(&loaded, Some(&new)) {
                new_after_cut += 1;
            } else {
                assert!(is(&loaded, old.as_ref()), "n {n}, cut {cut} of {cost}: loaded {loaded:?}");
            }
            let next = record_after(n + 2);
            s.save(&next).unwrap_or_else(|e| panic!("n {n}, cut {cut}: save after the cut: {e:?}"));
            assert!(is(&s.load(), Some(&next)), "n {n}, cut {cut}: load after the repair");
            cuts += 1;
        }
    }
    println!("power-loss sweep: {cuts} cut points, new record complete at {new_after_cut} of them");
    assert!(cuts > 10 * 760);
}

/// A power cut at every byte of a maintenance reset: afterwards the range holds the old record
/// or nothing, and it works again.
#[test]
fn power_cut_during_a_reset_leaves_old_or_nothing() {
    let base = flash_with(3);
    for cut in (0..Flash::CAPACITY as u32).step_by(7) {
        let mut flash = base.clone();
        flash.cut_power_after(cut);
        let mut s = store(flash);
        assert!(s.reset().is_err());
        let mut flash = s.into_flash();
        flash.power_on();
        let mut s = store(flash);
        let loaded = s.load();
        assert!(is(&loaded, Some(&record_after(3))) || is(&loaded, None), "cut {cut}: {loaded:?}");
        s.save(&record_after(9)).unwrap();
        assert!(is(&s.load(), Some(&record_after(9))));
    }
}

/// Every byte of the flash corrupted in turn (three masks: one bit, a nibble, the whole byte):
/// the load gives the newest record, the one before it, nothing, or an error — never a record
/// that was not saved. A corrupted byte of the newest record's data is always detected.
#[test]
fn every_corrupted_byte_is_detected_or_harmless() {
    let base = flash_with(3);
    let newest = record_after(3);
    let previous = record_after(2);
    let mut encoded = [0u8; HealthRecord::ENCODED_LEN];
    newest.encode(&mut encoded).unwrap();
    let image: Vec<u8> = (0..Flash::CAPACITY).map(|i| base.byte(i).unwrap()).collect();
    let at = image.windows(encoded.len()).position(|w| w == encoded).expect("the newest copy is in flash");
    let mut detected = 0;
    for offset in 0..Flash::CAPACITY {
        for mask in [0x01u8, 0xF0, 0xFF] {
            let mut flash = base.clone();
            flash.flip(offset, mask);
            let mut s = store(flash);
            let loaded = s.load();
            let ok = is(&loaded, Some(&newest)) || is(&loaded, Some(&previous)) || is(&loaded, None) || loaded.is_err();
            assert!(ok, "offset {offset} mask {mask:#x}: {loaded:?}");
            if (at..at + encoded.len()).contains(&offset) {
                assert!(!is(&loaded, Some(&newest)), "offset {offset}: corrupted data not detected");
                detected += 1;
            }
        }
    }
    assert_eq!(detected, 3 * encoded.len());
}

/// N saves spread their erases evenly over the pages.
#[test]
fn wear_is_spread_over_the_pages() {
    let mut s = store(Flash::new());
    for i in 1..=400 {
        s.save(&record_after(i % 50)).unwrap();
    }
    let counts = *s.into_flash().erase_counts();
    println!("wear: 400 saves, erases per page {counts:?}");
    let (min, max) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
    assert!(max - min <= 1, "erases per page {counts:?}");
    // two records per page: one erase per two saves, spread over 4 pages
    assert!((45..=55).contains(min), "erases per page {counts:?}");
}

#[test]
fn block_on_gives_up_on_a_future_that_never_completes() {
    assert_eq!(block_on(core::future::pending::<()>()), None);
    assert_eq!(block_on(async { 7 }), Some(7));
}

/// On 128 KiB pages (the STM32F446's sectors, here with 4-byte words) a page holds
/// `(131 072 − 2 page-state words) / 868 bytes per copy` = 150 copies before the store moves on
/// and erases: the formula of `docs/persistence.md`, "Wear".
#[test]
fn a_large_page_holds_the_computed_number_of_copies() {
    let mut flash = Box::new(RamFlash::<2, 131_072>::new());
    let r = record_after(3);
    let mut saves = 0;
    while flash.erase_counts().iter().sum::<u32>() == 0 {
        HealthStore::new(&mut *flash, 0..262_144).unwrap().save(&r).unwrap();
        saves += 1;
    }
    assert_eq!(saves - 1, (131_072 - 2 * 4) / (8 + 860), "copies on the first page");
}

#[test]
fn commissioning_windows_are_kept_beside_the_record() {
    use crate::conditioning::ConditionedWindow;
    let mut flash = Box::new(RamFlash::<8, 4096>::new());
    let mut s = HealthStore::new(&mut *flash, 0..RamFlash::<8, 4096>::CAPACITY as u32).unwrap();
    let window = |phase: f32| {
        ConditionedWindow::<2200>::from_samples((0..2125).map(|j| 4.5 + 4.0 * libm::sinf(0.01 * j as f32 + phase)))
            .unwrap()
    };
    let mut buffer = [0u8; window::window_encoded_len(2200) + 32];
    let record = record_after(3);
    s.save(&record).unwrap();
    s.keep_window(0, &window(0.0), -20.0, &mut buffer).unwrap();
    s.keep_window(1, &window(1.0), 35.0, &mut buffer).unwrap();
    for _ in 0..30 {
        s.save(&record).unwrap();
    }
    let mut out = ConditionedWindow::<2200>::new();
    assert_eq!(s.load_window(1, &mut out, &mut buffer), Ok(Some(35.0)));
    assert!(out.current_a().zip(window(1.0).current_a()).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(s.load_window(0, &mut out, &mut buffer), Ok(Some(-20.0)));
    assert_eq!(s.load_window(2, &mut out, &mut buffer), Ok(None));
    assert!(s.load_window(WINDOW_SLOTS, &mut out, &mut buffer).is_err());
    assert!(is(&s.load(), Some(&record)));
    // a buffer too small for the window is an error value
    assert!(s.keep_window(2, &window(2.0), 0.0, &mut [0u8; 1024]).is_err());
    assert!(s.load_window(1, &mut out, &mut [0u8; 1024]).is_err());
    // a slot kept again replaces the old window; a window kept after a cut mid-way cannot be
    // read as another
    s.keep_window(1, &window(3.0), 5.0, &mut buffer).unwrap();
    assert_eq!(s.load_window(1, &mut out, &mut buffer), Ok(Some(5.0)));
    assert!(out.current_a().zip(window(3.0).current_a()).all(|(a, b)| a.to_bits() == b.to_bits()));
}

/// A slot kept again with a window of the same length, the power cut every 61 bytes of the keep
/// (clean cuts): the slot reads as the old window, as empty, or as the new one once complete,
/// never as chunks of both.
#[test]
fn a_window_kept_again_and_cut_never_reads_as_two_windows_spliced() {
    use crate::conditioning::ConditionedWindow;
    let window = |phase: f32| {
        ConditionedWindow::<600>::from_samples((0..600).map(|j| 4.5 + 4.0 * libm::sinf(0.01 * j as f32 + phase)))
            .unwrap()
    };
    let same = |a: &ConditionedWindow<600>, b: &ConditionedWindow<600>| {
        a.len() == b.len() && a.current_a().zip(b.current_a()).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    let mut buffer = [0u8; window::window_encoded_len(600)];
    let mut s = HealthStore::new(RamFlash::<8, 2048>::new(), 0..16_384).unwrap();
    s.save(&record_after(2)).unwrap();
    s.keep_window(1, &window(0.0), -5.0, &mut buffer).unwrap();
    let base = s.into_flash();
    let (mut outcomes, mut cut) = ([0u32; 3], 0);
    loop {
        let mut flash = base.clone();
        flash.cut_power_after(cut);
        let mut s = HealthStore::new(flash, 0..16_384).unwrap();
        let done = s.keep_window(1, &window(2.0), 7.0, &mut buffer).is_ok();
        let mut flash = s.into_flash();
        flash.power_on();
        let mut s = HealthStore::new(flash, 0..16_384).unwrap();
        let mut out = ConditionedWindow::<600>::new();
        match s.load_window(1, &mut out, &mut buffer) {
            Ok(Some(t)) if t == -5.0 => assert!(same(&out, &window(0.0)), "cut {cut}"),
            Ok(Some(t)) => assert!(t == 7.0 && same(&out, &window(2.0)), "cut {cut}: {t}"),
            Ok(None) => {}
            Err(e) => panic!("cut {cut}: {e:?}"),
        }
        let k = match s.load_window(1, &mut out, &mut buffer) {
            Ok(Some(t)) if t == -5.0 => 0,
            Ok(None) => 1,
            _ => 2,
        };
        outcomes[k] += 1;
        if done {
            break;
        }
        cut += 61;
    }
    assert!(outcomes[0] > 0 && outcomes[1] > 10 && outcomes[2] > 0, "old, empty, new: {outcomes:?}");
}

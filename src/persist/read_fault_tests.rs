//! Host tests of what a failed load may do to the stored history ([`super::kept`]): reads that
//! fail on demand ([`RamFlash::fail_reads_after`]) anywhere in a load, once or for good, and a
//! record of another format version. A failed load gives an error, never an older record or
//! none; the record it leaves in RAM is not saved, and nothing is written or erased, so the next
//! good load gives the whole history; only a maintenance reset erases it.

use super::store::RECORD_KEY;
use super::tests::{flash_with, is, record_after, report, store, Flash, RANGE};
use super::*;

/// Every byte of `flash`.
fn image(flash: &Flash) -> Vec<u8> {
    (0..Flash::CAPACITY).map(|i| flash.byte(i).unwrap()).collect()
}

/// One boot as both firmwares run it under the policy: load, a flight added to the record in
/// RAM, and a save only of what [`KeptRecord::savable`] gives. Returns the record's origin.
fn boot(flash: Flash) -> (RecordOrigin, Flash) {
    let mut s = store(flash);
    let mut kept = KeptRecord::from_load(s.load());
    let cold = !kept.record().has_prior();
    kept.record_mut().new_flight(&report([0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]), cold);
    if let Some(r) = kept.savable() {
        s.save(r).unwrap();
    }
    (kept.origin(), s.into_flash())
}

#[test]
fn injected_read_faults_fail_the_reads_asked_for_and_change_nothing() {
    use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
    let mut flash = flash_with(3);
    let before = image(&flash);
    let mut buf = [0u8; 16];
    let reads = flash.reads();
    flash.fail_reads_after(2, 3);
    let results: Vec<bool> = (0..7).map(|_| flash.read(0, &mut buf).is_ok()).collect();
    assert_eq!(results, [true, true, false, false, false, true, true]);
    assert_eq!(flash.reads() - reads, 7);
    flash.fail_reads_after(0, u32::MAX);
    assert!((0..1000).all(|_| flash.read(64, &mut buf) == Err(RamFlashError::ReadFault)));
    // writes and erases go on; the contents change only through them
    assert_eq!(image(&flash), before);
    flash.erase(2048, 4096).unwrap();
    flash.write(2048, &[0x12, 0x34, 0x56, 0x78]).unwrap();
    flash.fail_reads_after(0, 0);
    flash.read(2048, &mut buf[..4]).unwrap();
    assert_eq!(buf[..4], [0x12, 0x34, 0x56, 0x78]);
}

/// A read fault at every read of a load, with the store at each position of its page cycle
/// (1 to 9 saves on four pages of two records): the load is an error, never the record before
/// the newest nor none; nothing is written or erased; the next load gives the newest record.
#[test]
fn a_read_fault_anywhere_in_a_load_is_an_error_never_an_older_record() {
    let mut faults = 0;
    for n in 1..=9u32 {
        let base = flash_with(n);
        let newest = record_after(n);
        let reads = {
            let mut s = store(base.clone());
            assert!(is(&s.load(), Some(&newest)));
            s.into_flash().reads() - base.reads()
        };
        assert!(reads > 4, "a load reads the page states and the items");
        for at in 0..reads {
            let mut flash = base.clone();
            let (image_before, touched) = (image(&flash), flash.touched_bytes());
            flash.fail_reads_after(at, 1);
            let mut s = store(flash);
            assert_eq!(s.load(), Err(StoreError::Flash(FlashFault::Other)), "{n} saves, read {at} of {reads}");
            let flash = s.into_flash();
            assert_eq!((image(&flash), flash.touched_bytes()), (image_before, touched), "{n} saves, read {at}");
            let mut s = store(flash);
            assert!(is(&s.load(), Some(&newest)), "{n} saves, read {at}: the next load");
            faults += 1;
        }
    }
    println!("read faults: {faults} loads, each with one failed read");
    assert!(faults > 100);
}

/// A store of K flights, one failed load: the flight's record is not saved, nothing is written,
/// and the next load gives the K flights with their history; the flight after it is saved on top.
#[test]
fn a_failed_load_saves_nothing_and_the_next_load_gives_the_history() {
    let k = 9;
    let mut flash = flash_with(k);
    let before = (image(&flash), flash.touched_bytes());
    flash.fail_reads_after(0, 1);
    let (origin, flash) = boot(flash);
    assert_eq!(origin, RecordOrigin::Unreadable(StoreError::Flash(FlashFault::Other)));
    assert_eq!((image(&flash), flash.touched_bytes()), before, "the store is left as it is");
    let mut s = store(flash);
    let loaded = s.load();
    assert!(is(&loaded, Some(&record_after(k))), "the history is intact: {loaded:?}");
    let (origin, flash) = boot(s.into_flash());
    assert_eq!(origin, RecordOrigin::Loaded);
    let next = store(flash).load().unwrap().unwrap();
    assert_eq!(next.flights(), k + 1);
    let friction = next.history(crate::faults::FaultMode::Friction);
    let flights: Vec<u32> = friction.iter().map(|e| e.flight).collect();
    assert_eq!(flights, (1..=k + 1).collect::<Vec<_>>(), "the flights before the failed load, then the new one");
    assert!(friction.iter().take(k as usize).eq(record_after(k).history(crate::faults::FaultMode::Friction).iter()));
}

/// A read that fails at every boot never lets a save through: thirty boots write and erase
/// nothing; once the reads work, the history is there.
#[test]
fn a_read_that_keeps_failing_never_overwrites_the_record() {
    let mut flash = flash_with(5);
    let before = (image(&flash), flash.touched_bytes());
    flash.fail_reads_after(0, u32::MAX);
    for b in 0..30 {
        let (origin, f) = boot(flash);
        assert!(matches!(origin, RecordOrigin::Unreadable(_)), "boot {b}: {origin:?}");
        flash = f;
    }
    assert_eq!((image(&flash), flash.touched_bytes()), before);
    flash.fail_reads_after(0, 0);
    assert!(is(&store(flash).load(), Some(&record_after(5))));
}

/// A record of another format version (a newer firmware's) does not decode: every boot reads
/// it as unreadable and saves nothing, so it stays the store's newest item, byte for byte.
#[test]
fn a_record_of_another_version_is_never_overwritten() {
    use sequential_storage::cache::Cache;
    use sequential_storage::map::{MapConfig, MapStorage};
    let mut foreign = [0u8; HealthRecord::ENCODED_LEN];
    record_after(4).encode(&mut foreign).unwrap();
    foreign[0] = RECORD_VERSION + 1;
    let mut flash = flash_with(4);
    let newest_item = |flash: &mut Flash| {
        let mut map =
            MapStorage::<u8, _, _>::new(Blocking(flash), MapConfig::try_new(RANGE).unwrap(), Cache::new_uncached());
        let mut buf = [0u8; 1024];
        block_on(map.fetch_item::<&[u8]>(&mut buf, &RECORD_KEY)).unwrap().unwrap().map(<[u8]>::to_vec)
    };
    {
        let mut map = MapStorage::<u8, _, _>::new(
            Blocking(&mut flash),
            MapConfig::try_new(RANGE).unwrap(),
            Cache::new_uncached(),
        );
        let mut buf = [0u8; 1024];
        block_on(map.store_item(&mut buf, &RECORD_KEY, &&foreign[..])).unwrap().unwrap();
    }
    let before = (image(&flash), flash.touched_bytes());
    for b in 0..5 {
        let (origin, f) = boot(flash);
        assert_eq!(
            origin,
            RecordOrigin::Unreadable(StoreError::Record(RecordError::Version(RECORD_VERSION + 1))),
            "boot {b}"
        );
        flash = f;
    }
    assert_eq!((image(&flash), flash.touched_bytes()), before);
    assert_eq!(newest_item(&mut flash).as_deref(), Some(&foreign[..]));
}

/// The maintenance reset still erases after a failed load, whether the read fault passed or
/// lasts: the next good load finds no record, and a new history starts and is saved.
#[test]
fn a_maintenance_reset_after_a_failed_load_erases_the_record() {
    for failing in [1, u32::MAX] {
        let mut flash = flash_with(6);
        flash.fail_reads_after(0, failing);
        let mut s = store(flash);
        assert!(matches!(KeptRecord::from_load(s.load()).origin(), RecordOrigin::Unreadable(_)));
        s.reset().unwrap();
        let mut flash = s.into_flash();
        assert!(image(&flash).iter().all(|&b| b == 0xFF), "failing {failing}: the range is erased");
        flash.fail_reads_after(0, 0);
        let (origin, flash) = boot(flash);
        assert_eq!(origin, RecordOrigin::Empty);
        let loaded = store(flash).load().unwrap().unwrap();
        assert_eq!(loaded.flights(), 1, "failing {failing}: a new history");
    }
}

#[test]
fn only_a_loaded_or_empty_record_may_be_saved() {
    let loaded = KeptRecord::from_load(Ok(Some(record_after(3))));
    assert_eq!((loaded.origin(), loaded.may_save(), loaded.needs_load()), (RecordOrigin::Loaded, true, false));
    assert!(loaded.savable().is_some_and(|r| r.same_bits(&record_after(3))));
    let empty = KeptRecord::from_load(Ok(None));
    assert_eq!(empty.origin(), RecordOrigin::Empty);
    assert!(empty.savable().is_some_and(|r| r.same_bits(&HealthRecord::new())));
    let unreadable = KeptRecord::from_load(Err(StoreError::Corrupt));
    assert_eq!((unreadable.origin(), unreadable.needs_load()), (RecordOrigin::Unreadable(StoreError::Corrupt), true));
    assert!(unreadable.savable().is_none() && unreadable.record().same_bits(&HealthRecord::new()));
    // the record of another unit replaced in RAM but not archived: the store's newest copy is
    // still that record, so the new one is not saved and the next flight loads again
    let mut foreign = KeptRecord::from_load(Ok(Some(record_after(3))));
    *foreign.record_mut() = HealthRecord::for_unit(RecordIdentity { params: 7, unit_serial: 1 });
    foreign.archive_failed(StoreError::Full);
    assert_eq!(foreign.origin(), RecordOrigin::NotArchived(StoreError::Full));
    assert!(foreign.savable().is_none() && foreign.needs_load());
    let labels = [loaded.origin(), empty.origin(), unreadable.origin(), foreign.origin()].map(RecordOrigin::label);
    assert_eq!(labels, ["loaded", "empty", "unreadable", "not_archived"]);
}

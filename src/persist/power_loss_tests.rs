//! Power loss as a NOR flash suffers it: a cut tears the word being written (a random subset of
//! the bits its write was clearing) and leaves the page being erased undefined
//! ([`RamFlash::set_tearing`]).

use embedded_storage::nor_flash::NorFlash;

use super::*;
use crate::optimizer::rng::splitmix64_mix;

// ---- the tearing itself ----------------------------------------------------------------------

/// A write cut in its third word: the two words before are written, the words after untouched,
/// and the third holds only bits of the old word and the new one, each bit it was clearing
/// cleared or not at random: over the seeds, a torn word is neither always the old word nor
/// always the new one, nor a byte prefix of it.
#[test]
fn a_cut_write_tears_its_word_into_a_random_subset_of_the_bits_it_clears() {
    let old: [u8; 16] =
        [0xF0, 0xFF, 0x3C, 0xFF, 0xFF, 0xAA, 0xFF, 0x0F, 0xFE, 0xEF, 0x77, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF];
    let new: [u8; 16] =
        [0x00, 0x0F, 0x14, 0x81, 0x22, 0x00, 0x7E, 0x0C, 0x10, 0x01, 0x40, 0x00, 0x12, 0x34, 0x56, 0x78];
    let (mut partial, mut unchanged, mut complete, mut mixed_bytes) = (0, 0, 0, 0);
    for s in 0..64u64 {
        let mut flash = RamFlash::<2, 256>::new();
        flash.write(0, &old).unwrap();
        flash.set_tearing(Some(splitmix64_mix(s)));
        flash.cut_power_after(8 + (s % 4) as u32); // a byte of the third word
        assert_eq!(flash.write(0, &new), Err(RamFlashError::PowerLoss));
        let got: Vec<u8> = (0..16).map(|i| flash.byte(i).unwrap()).collect();
        for i in 0..8 {
            assert_eq!(got[i], old[i] & new[i], "seed {s}: byte {i} written");
        }
        for i in 12..16 {
            assert_eq!(got[i], old[i], "seed {s}: byte {i} untouched");
        }
        for i in 8..12 {
            // only bits the write was clearing may be cleared, and no bit is set
            let clearing = old[i] & !new[i];
            assert_eq!(got[i] | clearing, old[i], "seed {s}: byte {i}");
        }
        let word = &got[8..12];
        let (old_word, new_word): (Vec<u8>, Vec<u8>) = (8..12).map(|i| (old[i], old[i] & new[i])).unzip();
        if word == old_word.as_slice() {
            unchanged += 1;
        } else if word == new_word.as_slice() {
            complete += 1;
        } else {
            partial += 1;
        }
        // a byte prefix would leave every byte old or new: a torn word has bytes that are neither
        mixed_bytes += (8..12).filter(|&i| got[i] != old[i] && got[i] != old[i] & new[i]).count();
    }
    assert!(partial > 50, "torn words: {partial} partial, {unchanged} unchanged, {complete} complete");
    assert!(mixed_bytes > 50, "bytes neither old nor written: {mixed_bytes}");
    let mut flash = RamFlash::<2, 256>::new();
    flash.write(0, &old).unwrap();
    flash.cut_power_after(9);
    assert!(flash.write(0, &new).is_err());
    assert_eq!(flash.byte(8), Some(old[8] & new[8]), "a clean cut keeps the byte prefix");
    assert_eq!(flash.byte(9), Some(old[9]));
}

/// An erase cut in its second page: the first page is erased, the pages after untouched, and the
/// second holds old bytes, `0xFF`, half-erased bytes (old bits kept, some set) and other bytes,
/// not a clean prefix, with a share of erased bytes that follows the cut's point in the page.
/// The same seed gives the same page.
#[test]
fn a_cut_erase_leaves_its_page_undefined() {
    const PAGE: usize = 1024;
    let mut base = RamFlash::<3, PAGE>::new();
    let image: Vec<u8> = (0..3 * PAGE).map(|i| splitmix64_mix(i as u64) as u8 & 0x7E).collect();
    base.write(0, &image).unwrap();
    let mut kinds = [0usize; 4]; // old, 0xFF, half-erased, other
    for (k, at) in [0, PAGE / 4, PAGE / 2, 3 * PAGE / 4, PAGE - 1].into_iter().enumerate() {
        for s in 0..4u64 {
            let mut flash = base.clone();
            flash.set_tearing(Some(splitmix64_mix(100 * k as u64 + s)));
            flash.cut_power_after((PAGE + at) as u32);
            assert_eq!(flash.erase(0, 3 * PAGE as u32), Err(RamFlashError::PowerLoss));
            assert!((0..PAGE).all(|i| flash.byte(i) == Some(0xFF)), "the first page is erased");
            assert!((2 * PAGE..3 * PAGE).all(|i| flash.byte(i) == Some(image[i])), "the third is untouched");
            let page: Vec<u8> = (PAGE..2 * PAGE).map(|i| flash.byte(i).unwrap()).collect();
            let old = &image[PAGE..2 * PAGE];
            let erased = page.iter().filter(|&&b| b == 0xFF).count();
            let kept = page.iter().zip(old).filter(|(b, o)| b == o).count();
            let half = page.iter().zip(old).filter(|(&b, &o)| b != o && b != 0xFF && b & o == o).count();
            kinds[0] += kept;
            kinds[1] += erased;
            kinds[2] += half;
            kinds[3] += PAGE - kept - erased - half;
            // the erased share follows the erase's progress
            let progress = at as f64 / PAGE as f64;
            let share = erased as f64 / PAGE as f64;
            assert!((share - progress).abs() < 0.08, "cut at {at}: erased share {share:.2}");
            if at == 0 {
                assert!(kept > 0 && erased < PAGE / 50, "a cut as the erase starts leaves old bytes");
            }
            let mut again = base.clone();
            again.set_tearing(Some(splitmix64_mix(100 * k as u64 + s)));
            again.cut_power_after((PAGE + at) as u32);
            let _ = again.erase(0, 3 * PAGE as u32);
            assert!((0..3 * PAGE).all(|i| again.byte(i) == flash.byte(i)), "the same seed replays");
        }
    }
    assert!(kinds.iter().all(|&n| n > 200), "old, erased, half-erased, other bytes: {kinds:?}");
    // not a clean prefix: some cut leaves an erased byte after an old one
    let mut flash = base.clone();
    flash.set_tearing(Some(7));
    flash.cut_power_after((PAGE / 2) as u32);
    let _ = flash.erase(PAGE as u32, 2 * PAGE as u32);
    let page: Vec<u8> = (PAGE..2 * PAGE).map(|i| flash.byte(i).unwrap()).collect();
    let first_old = page.iter().zip(&image[PAGE..]).position(|(b, o)| b == o).unwrap();
    assert!(page[first_old..].contains(&0xFF), "an erased byte after an old one");
    // without tearing, a cut erase leaves an erased prefix
    let mut flash = base.clone();
    flash.cut_power_after((PAGE + 10) as u32);
    let _ = flash.erase(0, 3 * PAGE as u32);
    assert!((PAGE..PAGE + 10).all(|i| flash.byte(i) == Some(0xFF)));
    assert!((PAGE + 10..2 * PAGE).all(|i| flash.byte(i) == Some(image[i])));
}

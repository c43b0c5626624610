//! What the QEMU firmware asks of its semihosting host: the command line (the maintenance and
//! commissioning words) and the exit status.

use cortex_m_semihosting::debug;

/// The semihosting command-line word that commands a maintenance reset of the health record.
pub const MAINTENANCE_WORD: &[u8] = b"--maintenance";

/// The word that commands a maintenance reset followed by a commissioning of the unit.
pub const COMMISSION_WORD: &[u8] = b"--commission";

/// Bytes of the command line read ([`word_given`]); a longer line is no command.
const CMDLINE_LEN: usize = 256;

/// `true` when the semihosting command line (`SYS_GET_CMDLINE`, 0x15: the host writes the line,
/// NUL-terminated, into the buffer and its length into the block's second word) holds `word`,
/// words separated by spaces. A host that refuses the call, or a line longer than
/// [`CMDLINE_LEN`], is no command: the record stays.
#[inline(never)]
pub fn word_given(word: &[u8]) -> bool {
    let mut line = [0u8; CMDLINE_LEN];
    let mut block = [line.as_mut_ptr() as usize, CMDLINE_LEN];
    // SAFETY: SYS_GET_CMDLINE writes at most `block[1]` bytes into `line`, which lives through
    // the call, and its length into `block[1]`; both are read back volatile below, as the
    // compiler does not see the host's writes.
    let status =
        unsafe { cortex_m_semihosting::syscall1(cortex_m_semihosting::nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if status != 0 {
        return false;
    }
    // SAFETY: `block` is a live, aligned local.
    let len = unsafe { core::ptr::read_volatile(block.as_ptr().wrapping_add(1)) };
    // SAFETY: `line` is a live local array; volatile for the host's writes.
    let line = unsafe { core::ptr::read_volatile(&line) };
    line.get(..len.min(CMDLINE_LEN)).is_some_and(|l| l.split(|&b| b == b' ' || b == 0).any(|w| w == word))
}

/// Ends the QEMU run through semihosting: status 0 when `ok`, 1 otherwise.
pub fn exit(ok: bool) -> ! {
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    // not under a semihosting host (real board without debugger): park
    loop {
        cortex_m::asm::wfi();
    }
}

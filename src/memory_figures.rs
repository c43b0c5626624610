//! The firmware's memory figures from the linker symbols: the static RAM sections' sizes and the
//! peak stack, measured by painting the free stack at start-up ([`paint_stack`]) and finding the
//! lowest word no longer holding the paint at the end ([`stack_peak`]).

/// Word painted over the free stack at start-up.
const STACK_PAINT: u32 = 0x5AC5_5AC5;

/// Bytes below the current stack pointer left unpainted (the painter's own frame and a margin).
const PAINT_MARGIN: usize = 64;

extern "C" {
    // cortex-m-rt link.x: section bounds and the stack region [_stack_end, _stack_start).
    static __sdata: u32;
    static __edata: u32;
    static __sbss: u32;
    static __ebss: u32;
    static __suninit: u32;
    static __euninit: u32;
    static _stack_end: u32;
    static _stack_start: u32;
}

/// Sizes of the statically allocated RAM sections.
pub struct StaticRam {
    /// `.data`, bytes.
    pub data: usize,
    /// `.bss`, bytes.
    pub bss: usize,
    /// `.uninit`, bytes.
    pub uninit: usize,
}

impl StaticRam {
    /// All three sections.
    pub fn total(&self) -> usize {
        self.data + self.bss + self.uninit
    }
}

/// The static RAM sections' sizes.
pub fn static_ram() -> StaticRam {
    // Only the addresses of the linker symbols are used (`&raw const` on an extern static is safe).
    let span = |start: *const u32, end: *const u32| (end as usize).saturating_sub(start as usize);
    StaticRam {
        data: span(&raw const __sdata, &raw const __edata),
        bss: span(&raw const __sbss, &raw const __ebss),
        uninit: span(&raw const __suninit, &raw const __euninit),
    }
}

/// Bottom (lowest address) and top of the stack region.
fn stack_bounds() -> (usize, usize) {
    (&raw const _stack_end as usize, &raw const _stack_start as usize)
}

/// The stack region's size, bytes.
pub fn stack_size() -> usize {
    let (bottom, top) = stack_bounds();
    top.saturating_sub(bottom)
}

/// Fills the unused stack, from its bottom up to just below the current stack pointer, with
/// [`STACK_PAINT`]. Call it first, before any interrupt is enabled.
#[inline(never)]
pub fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let limit = (cortex_m::register::msp::read() as usize).saturating_sub(PAINT_MARGIN) & !3;
    let mut p = bottom as *mut u32;
    while (p as usize) < limit {
        // SAFETY: `p` is word-aligned (cortex-m-rt aligns `_stack_end` to 4) and lies in
        // [_stack_end, SP − margin): RAM reserved for the stack and below every live frame; no
        // interrupt is enabled yet, so nothing else uses it. Volatile, so the writes are kept.
        unsafe { p.write_volatile(STACK_PAINT) };
        p = p.wrapping_add(1);
    }
}

/// Peak stack use: from the top of the stack down to the lowest word no longer holding the paint.
pub fn stack_peak() -> usize {
    let (bottom, top) = stack_bounds();
    let mut p = bottom as *const u32;
    // SAFETY: reads aligned words of the stack region [bottom, top) only; volatile because the
    // compiler cannot know the stack itself wrote them.
    while (p as usize) < top && unsafe { p.read_volatile() } == STACK_PAINT {
        p = p.wrapping_add(1);
    }
    top.saturating_sub(p as usize)
}

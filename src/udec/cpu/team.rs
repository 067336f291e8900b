//! A team of threads that stays up for a whole CYCLE run and shares out the work of each stage.
//!
//! A cycle of a wall of 1000 blocks is two stages of some 50 and 150 µs with a few µs of serial
//! work between them. A general-purpose pool (rayon) puts its idle workers to sleep within
//! microseconds, and each stage then pays for waking them: a futex call, and on a virtual machine
//! an inter-processor interrupt to a halted virtual CPU — tens of µs per wake-up, more than the
//! work it shares on 16 threads (5.4e-4 s a cycle there, twice the time on 2 cores). The team's
//! helpers instead wait for the next stage spinning, then yielding, and only after a long pause
//! (a contact update, a checkpoint) sleeping; the thread that drives the cycle takes a share of
//! every stage itself, and no thread ever waits for a wake-up on the hot path.
//!
//! Work is handed out in chunks from a shared counter, so a helper that the system deschedules
//! (a busy 2-core machine) holds up one chunk, not a fixed share; and a helper joins a stage only
//! while the stage is open, so the driver, once it has run out of chunks, closes the stage and
//! waits only for helpers that hold one — never for a helper that has not been scheduled yet.
//! Which thread computes an element never changes its result, and every sum across elements is
//! taken serially by the caller, so a run repeats bit for bit on any number of threads.

use std::any::Any;
use std::cell::UnsafeCell;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// A stage's work: called once by each participant with its index (0 is the driver).
type Job<'a> = &'a (dyn Fn(usize) + Sync);

/// Spin-loop rounds a waiting thread tries before it starts yielding its core (a few µs).
const SPIN_ROUNDS: u32 = 2_000;
/// Whether the team pays: for every stage the driver times its own share and counts its
/// elements, which at its own pace prices the whole stage on one thread; over the last ~64
/// stages the team's time (the driver's share plus its wait for the helpers) is compared with
/// that price. On a machine busy with other work a helper is descheduled in mid-chunk now and
/// then, and the driver waits a scheduler time slice (milliseconds) for it; when that makes the
/// team no faster than the driver alone (`PAYS` of the price), the team runs the next
/// `PAUSE_MIN` stages on the driver alone, doubling the pause (up to `PAUSE_MAX`) while it keeps
/// not paying, and tries again. Results do not depend on it (see the module doc), only the time.
const PAYS: f64 = 0.9;
const PAUSE_MIN: u32 = 1_000;
const PAUSE_MAX: u32 = 64_000;
/// How long a helper waits for the next stage, spinning and yielding, before it sleeps.
const SLEEP_AFTER: Duration = Duration::from_millis(2);

/// The state the driver and its helpers share.
struct Shared {
    /// Generation of the current stage (high bits) and how many threads take part in it (low
    /// 16 bits), in one word so that a helper reads both at once.
    stage: AtomicU64,
    /// The current stage's work. Written by the driver before it publishes a new `stage`, read
    /// by the helpers that joined it, and not changed again until the stage is closed and every
    /// helper that joined has left.
    job: UnsafeCell<Option<Job<'static>>>,
    /// Who is at work on the current stage: its generation (high 32 bits), [`CLOSED`] once the
    /// driver has finished its own share, and the helpers that joined and have not left (low
    /// bits). A helper joins only an open stage of the generation it was told of.
    active: AtomicU64,
    /// Set, with a last new `stage`, when the run ends.
    stop: AtomicBool,
    /// A panic raised in a helper's share, passed to the driver.
    panic: Mutex<Option<Box<dyn Any + Send>>>,
    /// Where helpers sleep after a long pause, and how many do.
    sleep: Mutex<()>,
    wake: Condvar,
    sleepers: AtomicUsize,
}

// SAFETY: `job` is written only by the driver while no helper can read it (before the `stage`
// publication, or once the stage is closed and no helper is left in it); helpers read it only
// after joining an open stage and before leaving it.
unsafe impl Sync for Shared {}

const PARTICIPANTS_BITS: u32 = 16;
/// The "closed" bit of `Shared::active`, and the mask of its count of helpers.
const CLOSED: u64 = 1 << 31;
const COUNT: u64 = CLOSED - 1;

/// The driver's handle on its team: `size` threads, itself included.
pub struct Team<'t> {
    shared: &'t Shared,
    size: usize,
    generation: u64,
    /// Moving sums over the last ~64 stages of the team's time and of the driver-alone price
    /// (see [`PAYS`]), and the stages they have seen since the last pause.
    team_time: f64,
    alone_price: f64,
    seen: u32,
    /// Stages left to run on the driver alone, and how many the next pause lasts.
    alone_for: u32,
    pause: u32,
}

/// Runs `f` with a team of `size` threads (the calling thread and `size − 1` helpers, none when
/// `size` ≤ 1). The helpers end with `f`.
pub fn with_team<R>(size: usize, f: impl FnOnce(&mut Team) -> R) -> R {
    let size = size.clamp(1, (1 << PARTICIPANTS_BITS) - 1);
    let shared = Shared {
        stage: AtomicU64::new(0),
        job: UnsafeCell::new(None),
        active: AtomicU64::new(CLOSED),
        stop: AtomicBool::new(false),
        panic: Mutex::new(None),
        sleep: Mutex::new(()),
        wake: Condvar::new(),
        sleepers: AtomicUsize::new(0),
    };
    let team = |shared| Team { shared, size, generation: 0, team_time: 0.0, alone_price: 0.0, seen: 0, alone_for: 0, pause: PAUSE_MIN };
    if size == 1 {
        return f(&mut team(&shared));
    }
    std::thread::scope(|s| {
        for h in 1..size {
            let shared = &shared;
            s.spawn(move || helper(shared, h));
        }
        // Whatever way `f` ends, the helpers are told to stop, so that the scope can join them.
        struct StopOnDrop<'a>(&'a Shared);
        impl Drop for StopOnDrop<'_> {
            fn drop(&mut self) {
                self.0.stop.store(true, Ordering::Release);
                self.0.stage.fetch_add(1 << PARTICIPANTS_BITS, Ordering::Release);
                wake_sleepers(self.0);
            }
        }
        let _stop = StopOnDrop(&shared);
        f(&mut team(&shared))
    })
}

impl Team<'_> {
    /// Runs `job` on `participants` threads of the team (at most its size; the driver is
    /// participant 0) and returns when all have finished, with how long the driver's own share
    /// took and how long it then waited for the helpers (zero when it ran alone).
    pub fn run(&mut self, participants: usize, job: Job) -> (Duration, Duration) {
        let p = participants.clamp(1, self.size);
        if p == 1 || self.alone_for > 0 {
            self.alone_for = self.alone_for.saturating_sub(1);
            job(0);
            return (Duration::ZERO, Duration::ZERO);
        }
        let shared = self.shared;
        // SAFETY: no helper can read `job` now (the last stage is closed and empty), and the
        // reference stays valid until this stage is closed and empty too, below, before this
        // function returns — on a panic as well.
        unsafe { *shared.job.get() = Some(std::mem::transmute::<Job, Job<'static>>(job)) };
        self.generation += 1;
        shared.active.store((self.generation & 0xFFFF_FFFF) << 32, Ordering::Relaxed);
        shared.stage.store(self.generation << PARTICIPANTS_BITS | p as u64, Ordering::Release);
        wake_sleepers(shared);
        let started = Instant::now();
        let own = catch_unwind(AssertUnwindSafe(|| job(0)));
        // No helper joins from now on; wait for those in it.
        let closed = Instant::now();
        shared.active.fetch_or(CLOSED, Ordering::AcqRel);
        wait_until(|| shared.active.load(Ordering::Acquire) & COUNT == 0);
        let waited = closed.elapsed();
        // SAFETY: no helper is in the stage and none can join it.
        unsafe { *shared.job.get() = None };
        if let Err(e) = own {
            resume_unwind(e);
        }
        if let Some(e) = shared.panic.lock().unwrap_or_else(|p| p.into_inner()).take() {
            resume_unwind(e);
        }
        (closed - started, waited)
    }

    /// Books a stage the team ran: `own` and `waited` from [`Team::run`], the driver's share
    /// `mine` of the stage's `n` elements (see [`PAYS`]).
    fn book(&mut self, own: Duration, waited: Duration, mine: usize, n: usize) {
        if mine == 0 || own.is_zero() {
            return;
        }
        const KEEP: f64 = 63.0 / 64.0;
        self.team_time = KEEP * self.team_time + (own + waited).as_secs_f64();
        self.alone_price = KEEP * self.alone_price + own.as_secs_f64() * n as f64 / mine as f64;
        self.seen += 1;
        if self.seen < 64 {
            return;
        }
        if self.team_time > PAYS * self.alone_price {
            self.alone_for = self.pause;
            self.pause = (2 * self.pause).min(PAUSE_MAX);
            (self.team_time, self.alone_price, self.seen) = (0.0, 0.0, 0);
        } else if self.team_time < 0.5 * PAYS * self.alone_price {
            self.pause = PAUSE_MIN;
        }
    }

    /// Runs `f` over `0..n` cut into consecutive chunks of at least `min_chunk` elements, on as
    /// many threads as give each at least `min_per_thread` elements. `f(range)` must only touch
    /// what belongs to its range.
    pub fn for_chunks(&mut self, n: usize, min_per_thread: usize, min_chunk: usize, f: &(dyn Fn(std::ops::Range<usize>) + Sync)) {
        let p = (n / min_per_thread.max(1)).clamp(1, self.size);
        if p == 1 {
            return f(0..n);
        }
        // Several chunks per thread, so that one held up does not hold up the stage.
        let chunk = n.div_ceil(4 * p).max(min_chunk).max(1);
        let next = AtomicUsize::new(0);
        let mine = AtomicUsize::new(0);
        let (own, waited) = self.run(p, &|i| loop {
            let start = next.fetch_add(chunk, Ordering::Relaxed);
            if start >= n {
                break;
            }
            let end = (start + chunk).min(n);
            f(start..end);
            if i == 0 {
                mine.fetch_add(end - start, Ordering::Relaxed);
            }
        });
        self.book(own, waited, mine.into_inner(), n);
    }
}

fn wake_sleepers(shared: &Shared) {
    if shared.sleepers.load(Ordering::SeqCst) > 0 {
        let _g = shared.sleep.lock().unwrap_or_else(|p| p.into_inner());
        shared.wake.notify_all();
    }
}

/// Waits for `done`: spinning for a few µs, then yielding the core to whatever else wants it.
fn wait_until(done: impl Fn() -> bool) {
    for _ in 0..SPIN_ROUNDS {
        if done() {
            return;
        }
        std::hint::spin_loop();
    }
    while !done() {
        std::thread::yield_now();
    }
}

/// A helper's life: wait for a stage, do its share when it takes part, report, until the stop.
fn helper(shared: &Shared, index: usize) {
    let mut seen = 0u64;
    loop {
        let word = wait_for_stage(shared, seen);
        seen = word >> PARTICIPANTS_BITS;
        if shared.stop.load(Ordering::Acquire) {
            return;
        }
        let participants = (word & ((1 << PARTICIPANTS_BITS) - 1)) as usize;
        if index < participants && join(shared, seen) {
            // SAFETY: this helper is in an open stage, so the driver keeps `job` in place until
            // it leaves.
            let job = unsafe { (*shared.job.get()).expect("a published stage has a job") };
            if let Err(e) = catch_unwind(AssertUnwindSafe(|| job(index))) {
                shared.panic.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(e);
            }
            shared.active.fetch_sub(1, Ordering::Release);
        }
    }
}

/// Joins stage `generation` if it is still the current one and open.
fn join(shared: &Shared, generation: u64) -> bool {
    let mut a = shared.active.load(Ordering::Acquire);
    loop {
        if a >> 32 != generation & 0xFFFF_FFFF || a & CLOSED != 0 {
            return false;
        }
        match shared.active.compare_exchange_weak(a, a + 1, Ordering::AcqRel, Ordering::Acquire) {
            Ok(_) => return true,
            Err(now) => a = now,
        }
    }
}

/// Waits until the stage generation differs from `seen`; returns the stage word.
fn wait_for_stage(shared: &Shared, seen: u64) -> u64 {
    let fresh = || {
        let w = shared.stage.load(Ordering::Acquire);
        (w >> PARTICIPANTS_BITS != seen).then_some(w)
    };
    for _ in 0..SPIN_ROUNDS {
        if let Some(w) = fresh() {
            return w;
        }
        std::hint::spin_loop();
    }
    let since = Instant::now();
    loop {
        if let Some(w) = fresh() {
            return w;
        }
        if since.elapsed() < SLEEP_AFTER {
            std::thread::yield_now();
            continue;
        }
        // A long pause: sleep until the driver publishes a stage. `sleepers` is raised before
        // the last look, under the lock the driver takes to wake sleepers, so no wake-up is lost;
        // the timeout is a second guard.
        let guard = shared.sleep.lock().unwrap_or_else(|p| p.into_inner());
        shared.sleepers.fetch_add(1, Ordering::SeqCst);
        if let Some(w) = fresh() {
            shared.sleepers.fetch_sub(1, Ordering::SeqCst);
            return w;
        }
        let (g, _) = shared.wake.wait_timeout(guard, Duration::from_millis(10)).unwrap_or_else(|p| p.into_inner());
        drop(g);
        shared.sleepers.fetch_sub(1, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every element is visited exactly once, on any team size, over many stages, with pauses
    /// long enough for the helpers to fall asleep.
    #[test]
    fn chunks_cover_every_element_once() {
        for size in [1, 2, 3, 8] {
            with_team(size, |team| {
                let counts: Vec<AtomicUsize> = (0..10_007).map(|_| AtomicUsize::new(0)).collect();
                for stage in 0..200 {
                    team.for_chunks(counts.len(), 100, 16, &|r| {
                        for i in r {
                            counts[i].fetch_add(1, Ordering::Relaxed);
                        }
                    });
                    if stage % 50 == 0 {
                        std::thread::sleep(SLEEP_AFTER * 3);
                    }
                }
                assert!(counts.iter().all(|c| c.load(Ordering::Relaxed) == 200), "team of {size}");
            });
        }
    }

    /// A panic in any participant's share reaches the driver, after every share has ended.
    #[test]
    fn a_panic_in_a_share_reaches_the_driver() {
        let r = std::panic::catch_unwind(|| {
            with_team(4, |team| {
                let joined = AtomicUsize::new(0);
                team.run(4, &|i| {
                    joined.fetch_add(1, Ordering::SeqCst);
                    if i == 3 {
                        panic!("share 3 fails");
                    }
                    // The driver stays in the stage until every helper has joined it.
                    let since = Instant::now();
                    while i == 0 && joined.load(Ordering::SeqCst) < 4 && since.elapsed() < Duration::from_secs(20) {
                        std::thread::yield_now();
                    }
                });
            })
        });
        assert!(r.is_err());
    }
}

//! The learning windows (`--update-every`): which passes end one, so that the statistics
//! fold there. A window's passes sample with frozen posteriors, so direct light takes them in
//! one dispatch (src/render/passes.rs).

/// When the observations are folded into the posteriors (`--update-every`): after every K
/// learned passes, or (`auto`, the default) after every pass while the learning is young and
/// in longer windows later, each at most 1/8 of its age.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UpdateEvery {
    Passes(u32),
    Auto,
}

/// Where a session's learning stands: its learned passes (never going back), and its age for
/// `auto`: the passes of the current film once the camera, the size or the chunk changed (what
/// the film sees is new: new regions, in an animation new light positions), else all learned
/// passes (so a `--load-stats` continuation folds where the uninterrupted render folded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearningClock {
    pub passes: u32,
    pub age: u32,
}

impl LearningClock {
    /// The clock `k` passes later.
    pub fn after(self, k: u32) -> LearningClock {
        LearningClock {
            passes: self.passes + k,
            age: self.age + k,
        }
    }
}

impl UpdateEvery {
    /// The longest window of `auto`: 16 passes, from age 128 on.
    const AUTO_MAX: u32 = 16;

    /// `auto`'s window at `age`: 1 up to age 16, then the largest power of two ≤ age / 8, at
    /// most [`Self::AUTO_MAX`]: windows of 2 from age 16, 4 from 32, 8 from 64, 16 from 128.
    /// Each starts at a multiple of its length, so the windows depend only on the clock
    /// (never on how passes are batched).
    /// Why: a direct-light window is one dispatch, and on lavapipe a pass alone in its
    /// dispatch costs ~1.6× a pass among others (city, wang, 128×96: 2.5–2.9 s against
    /// 1.6–1.7 s for 512 passes), while statistics that have many passes in them barely move
    /// in a few more. rooms16, city, hall, strings (direct, 128×96, 256 spp): windows up to
    /// 1/16 of the age took 0.72–0.85× the time of windows of 1 with the variance within
    /// the seeds' noise; up to 1/8 (48 windows in 256 passes instead of 80) city 0.94× the
    /// time of 1/16 for 1.7 % more variance, the other three +0.0–0.2 % (six seeds); 1/4:
    /// city +3.4 %, strings +2.0 %, hardly faster. Windows of 4 from the start cost 12 %
    /// (city); `auto` on the learned passes alone 31 % more on a camera walk with carried
    /// learning, hence the film's age after a move (docs/results.md, 2026-12-03).
    fn auto_window(age: u32) -> u32 {
        let w = (age / 8).clamp(1, Self::AUTO_MAX);
        1 << (31 - w.leading_zeros())
    }

    /// The window's length and where the clock is in its count.
    fn window(self, c: LearningClock) -> (u32, u32) {
        match self {
            UpdateEvery::Passes(k) => (k, c.passes),
            UpdateEvery::Auto => (Self::auto_window(c.age), c.age),
        }
    }

    /// Whether a window ends at clock `c` (the statistics fold after the pass that brought
    /// the clock there).
    pub fn ends_at(self, c: LearningClock) -> bool {
        let (w, n) = self.window(c);
        n.is_multiple_of(w)
    }

    /// Passes from clock `c` to the end of the window that holds the next pass.
    pub fn to_window_end(self, c: LearningClock) -> u32 {
        let (w, n) = self.window(c);
        w - n % w
    }
}

impl std::str::FromStr for UpdateEvery {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s == "auto" {
            return Ok(UpdateEvery::Auto);
        }
        match s.parse::<u32>() {
            Ok(k) if k >= 1 => Ok(UpdateEvery::Passes(k)),
            _ => Err(format!(
                "'{s}' is neither a number of passes ≥ 1 nor 'auto'"
            )),
        }
    }
}

impl std::fmt::Display for UpdateEvery {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            UpdateEvery::Passes(k) => write!(f, "{k}"),
            UpdateEvery::Auto => f.write_str("auto"),
        }
    }
}

/// In reports: the number of passes, or "auto".
impl serde::Serialize for UpdateEvery {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            UpdateEvery::Passes(k) => s.serialize_u32(*k),
            UpdateEvery::Auto => s.serialize_str("auto"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{LearningClock, UpdateEvery};

    fn clock(passes: u32, age: u32) -> LearningClock {
        LearningClock { passes, age }
    }

    /// Auto: every pass a window up to age 16, then windows of 2, 4, 8, 16 that start at
    /// multiples of their length; every growth point (passes 1, 2, 4, …, 32 and every 64th)
    /// ends one; the window ends are the same whichever pass one asks from; a film's age
    /// restarts them. K passes: by learned passes alone.
    #[test]
    fn auto_windows() {
        let auto = UpdateEvery::Auto;
        let ends: Vec<u32> = (1..=300).filter(|&p| auto.ends_at(clock(p, p))).collect();
        let mut want: Vec<u32> = (1..=16).collect();
        for (from, to, w) in [(16, 32, 2), (32, 64, 4), (64, 128, 8), (128, 300, 16)] {
            want.extend((from + w..=to).step_by(w as usize));
        }
        assert_eq!(ends, want);
        for p in (64..100_000).step_by(64) {
            assert!(
                auto.ends_at(clock(p, p)),
                "growth point {p} is inside a window"
            );
        }
        for p in 0..2000 {
            let c = clock(p, p);
            let end = p + auto.to_window_end(c);
            assert!(auto.ends_at(clock(end, end)));
            assert!(
                (p + 1..end).all(|q| !auto.ends_at(clock(q, q))),
                "{p}: skipped an end"
            );
            assert!(UpdateEvery::auto_window(p) <= (p / 8).max(1));
        }
        // After a move the film's age counts: 1000 passes learned, the film's 5th: its own
        // window of 1; the film's 40th: of 4 (by the age, whatever the passes).
        assert!(auto.ends_at(clock(1000, 5)) && auto.ends_at(clock(1001, 6)));
        assert_eq!(auto.to_window_end(clock(1039, 39)), 1);
        assert!(!auto.ends_at(clock(1038, 39)) && auto.ends_at(clock(1037, 40)));
        let four = UpdateEvery::Passes(4);
        let ends: Vec<u32> = (1..=12)
            .filter(|&p| four.ends_at(clock(p, p % 5)))
            .collect();
        assert_eq!(ends, [4, 8, 12]);
        assert_eq!(four.to_window_end(clock(5, 0)), 3);
    }

    #[test]
    fn parses_and_prints() {
        assert_eq!("auto".parse(), Ok(UpdateEvery::Auto));
        assert_eq!("7".parse(), Ok(UpdateEvery::Passes(7)));
        assert!("0".parse::<UpdateEvery>().is_err());
        assert!("-1".parse::<UpdateEvery>().is_err());
        assert_eq!(UpdateEvery::Auto.to_string(), "auto");
        assert_eq!(UpdateEvery::Passes(3).to_string(), "3");
    }
}

//! `profile --timeline`: what a render spends between its passes, event by event. The learned
//! samplers' extra time over `wang` is mostly not in a pass but around the passes: a learning
//! window ends its dispatch and adds a fold, and a growth point reads the statistics back,
//! builds cuts, pools and uploads (docs/results.md, sixteenth and seventeenth sessions found
//! it with throw-away builds that timed each of them alone; this is that build, kept).
//! Plain data: the session (session/mod.rs) and the pass recorder (passes.rs) fill it.

/// One timed step of a render. Each is submitted and waited for on its own, which adds one
/// submission's wait to each (lavapipe ~0.04 ms, an NVIDIA H200 ~0.55 ms): the sum is a
/// little above an untimed render's seconds.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// `passes` passes in one submission (direct light: one dispatch; paths: a dispatch per
    /// bounce and pass), seconds `render`, then the fold of the learning window that ends
    /// there, seconds `fold` (`None` where no window ends).
    Passes {
        passes: u32,
        render: f64,
        fold: Option<f64>,
    },
    /// A growth point: regions that got cuts (`added`), and the seconds of its read-back, the
    /// new cuts and slots, the pooling of borrowed observations (with rebinding), and the
    /// submission of the uploads with the folds of new and re-pooled slots.
    Growth {
        added: usize,
        read: f64,
        cuts: f64,
        pool: f64,
        submit: f64,
    },
}

/// Summary rows (markdown) of `events`: passes and folds by window length, growth points by
/// part, and the whole.
pub fn table(events: &[Event]) -> String {
    use std::collections::BTreeMap;
    // Window length -> (dispatches, seconds rendering, folds, seconds folding).
    let mut by_len: BTreeMap<u32, (u32, f64, u32, f64)> = BTreeMap::new();
    let mut growth = (0u32, 0usize, [0.0f64; 4]);
    for e in events {
        match *e {
            Event::Passes {
                passes,
                render,
                fold,
            } => {
                let r = by_len.entry(passes).or_default();
                r.0 += 1;
                r.1 += render;
                if let Some(f) = fold {
                    r.2 += 1;
                    r.3 += f;
                }
            }
            Event::Growth {
                added,
                read,
                cuts,
                pool,
                submit,
            } => {
                growth.0 += 1;
                growth.1 += added;
                for (s, v) in growth.2.iter_mut().zip([read, cuts, pool, submit]) {
                    *s += v;
                }
            }
        }
    }
    let ms = |s: f64| 1e3 * s;
    let mut out =
        String::from("| step | count | ms each (mean) | ms in all |\n|---|---|---|---|\n");
    let mut total = 0.0;
    for (len, (n, render, folds, fold)) in &by_len {
        let passes = (*n * *len) as f64;
        out.push_str(&format!(
            "| passes in submissions of {len} | {} | {:.3} a pass | {:.1} |\n",
            *n * *len,
            ms(render / passes),
            ms(*render)
        ));
        if *folds > 0 {
            out.push_str(&format!(
                "| folds after windows of {len} | {folds} | {:.3} | {:.1} |\n",
                ms(fold / *folds as f64),
                ms(*fold)
            ));
        }
        total += render + fold;
    }
    let parts = [
        "read back",
        "new cuts and slots",
        "pooling and rebinding",
        "uploads and folds",
    ];
    if growth.0 > 0 {
        for (name, s) in parts.iter().zip(growth.2) {
            out.push_str(&format!(
                "| growth points ({} regions in all): {name} | {} | {:.3} | {:.1} |\n",
                growth.1,
                growth.0,
                ms(s / growth.0 as f64),
                ms(s)
            ));
            total += s;
        }
    }
    out.push_str(&format!("| the steps together | | | {:.1} |\n", ms(total)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_groups_windows_and_sums_growth() {
        let events = [
            Event::Passes {
                passes: 1,
                render: 0.002,
                fold: Some(0.0005),
            },
            Event::Growth {
                added: 3,
                read: 0.001,
                cuts: 0.002,
                pool: 0.003,
                submit: 0.004,
            },
            Event::Passes {
                passes: 1,
                render: 0.004,
                fold: Some(0.0015),
            },
            Event::Passes {
                passes: 4,
                render: 0.008,
                fold: None,
            },
        ];
        let t = table(&events);
        assert!(
            t.contains("| passes in submissions of 1 | 2 | 3.000 a pass | 6.0 |"),
            "{t}"
        );
        assert!(
            t.contains("| folds after windows of 1 | 2 | 1.000 | 2.0 |"),
            "{t}"
        );
        assert!(
            t.contains("| passes in submissions of 4 | 4 | 2.000 a pass | 8.0 |"),
            "{t}"
        );
        assert!(!t.contains("folds after windows of 4"), "{t}");
        assert!(
            t.contains(
                "| growth points (3 regions in all): pooling and rebinding | 1 | 3.000 | 3.0 |"
            ),
            "{t}"
        );
        assert!(t.contains("| the steps together | | | 26.0 |"), "{t}");
    }
}

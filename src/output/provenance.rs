//! What made a run's outputs (issue 27 item 8): the program's version and commit, the deck, the
//! backend, the adapter and precision the cycle ran on, and when. The log prints it as one line
//! under the banner (so that `> run.log` keeps it: the choice of backend also goes to stderr),
//! and the state JSON holds it under `provenance`.

/// The provenance of one run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Provenance {
    /// `blockdem`'s version (Cargo.toml).
    pub version: String,
    /// The commit the binary was built from (build.rs), or `unknown` for a build outside git.
    pub commit: String,
    /// The deck's path as given on the command line.
    pub deck: String,
    /// `cpu` or `gpu`.
    pub backend: String,
    /// The GPU adapter, "name (API, driver)"; `none` on the CPU. (Strings, never JSON `null`,
    /// which in the state file means a number that is not finite.)
    pub adapter: String,
    /// `f64` or `f32`: the precision the cycle runs in.
    pub precision: String,
    /// When the run started, UTC, ISO 8601 (`2026-11-26T06:30:00Z`).
    pub date: String,
}

impl Provenance {
    /// A run of `deck` on `backend` now, by this build.
    pub fn now(deck: &str, backend: &str, adapter: Option<String>, precision: &str) -> Provenance {
        let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            commit: option_env!("BLOCKDEM_COMMIT").unwrap_or("unknown").to_string(),
            deck: deck.to_string(),
            backend: backend.to_string(),
            adapter: adapter.unwrap_or_else(|| "none".into()),
            precision: precision.to_string(),
            date: utc_date(secs),
        }
    }

    /// The log's line: `BLOCKDEM 0.1.0 (COMMIT ffd8542)  DECK d.dat  BACKEND cpu  ADAPTER none
    /// PRECISION f64  DATE 2026-11-26T06:30:00Z`.
    pub fn line(&self) -> String {
        format!(
            "BLOCKDEM {} (COMMIT {})  DECK {}  BACKEND {}  ADAPTER {}  PRECISION {}  DATE {}",
            self.version, self.commit, self.deck, self.backend, self.adapter, self.precision, self.date
        )
    }
}

/// Seconds since 1970 as `YYYY-MM-DDThh:mm:ssZ`.
pub fn utc_date(secs: u64) -> String {
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    let s = secs % 86_400;
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", s / 3600, s / 60 % 60, s % 60)
}

/// Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm). Here, below `bench`, which
/// also dates its reports with it: `output` calling up into `bench` closed a module cycle.
pub(crate) fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    #[test]
    fn civil_dates() {
        assert_eq!(super::civil_from_days(0), (1970, 1, 1));
        assert_eq!(super::civil_from_days(20_779), (2026, 11, 22));
    }

    #[test]
    fn utc_dates() {
        assert_eq!(super::utc_date(0), "1970-01-01T00:00:00Z");
        assert_eq!(super::utc_date(20_779 * 86_400 + 3_723), "2026-11-22T01:02:03Z");
    }
}

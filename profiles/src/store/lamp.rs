//! Lamp readings in the store: what a nightly check measured where it rewrote no
//! profile. Profiles are written only when a display drifted beyond the limits, but
//! the lamp-life forecast needs every night's light; these rows keep it, beside the
//! runs, without pretending to be profiles (nothing can apply them).

use rusqlite::params;

use super::forecast::LampReading;
use super::{ProfileStore, StoreError, Timestamp, eye_text};
use crate::{DisplayKey, Eye};

/// One row of `lamp_readings` as read back.
struct Row {
    utc: String,
    display: u32,
    eye: String,
    tile: [u32; 2],
    primaries: [f64; 3],
    usage: [f64; 3],
    headroom: f64,
}

impl ProfileStore {
    /// Records the readings a nightly check (`source`, e.g. `recalibrate`) took at
    /// `utc` of the displays of `wall`, all in one transaction. Refused without writing
    /// anything when a reading belongs to another wall or holds a value that is not a
    /// positive finite luminance, usage or headroom, or when the store already has a
    /// reading of the same display and eye at that time.
    pub fn record_lamp_readings(
        &mut self,
        wall: &str,
        source: &str,
        readings: &[LampReading],
    ) -> Result<usize, StoreError> {
        for r in readings {
            check_reading(wall, r)?;
        }
        let (path, busy) = (self.path.clone(), self.busy_timeout);
        let e = |action, err| super::sql_err_after(&path, busy, action, err);
        let tx = self
            .conn
            .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
            .map_err(|err| e("starting the transaction", err))?;
        for r in readings {
            insert(&tx, source, r).map_err(|err| match err.sqlite_error_code() {
                Some(rusqlite::ErrorCode::ConstraintViolation) => StoreError::InvalidRun(format!(
                    "the store already has a lamp reading of {} at {}",
                    r.display, r.utc
                )),
                _ => e("recording lamp readings", err),
            })?;
        }
        tx.commit()
            .map_err(|err| e("committing lamp readings", err))?;
        Ok(readings.len())
    }

    /// Every lamp reading of projector `display` of `wall` (all its eyes), oldest
    /// first: the stored readings and the reading each stored profile records.
    pub fn lamp_readings(&self, wall: &str, display: u32) -> Result<Vec<LampReading>, StoreError> {
        let mut out: Vec<LampReading> = self
            .history(wall, display)?
            .iter()
            .map(|(t, p)| LampReading::of_profile(*t, p))
            .collect();
        let rows = self.query_all(
            "reading lamp readings",
            "SELECT measured_utc, display, eye, tile_col, tile_row,
                    red_cd_m2, green_cd_m2, blue_cd_m2, usage_red, usage_green, usage_blue,
                    headroom
             FROM lamp_readings WHERE wall = ?1 AND display = ?2",
            params![wall, display],
            read_row,
        )?;
        for row in rows {
            out.push(self.parse(wall, row)?);
        }
        out.sort_by(|a, b| a.utc.cmp(&b.utc).then(a.display.eye.cmp(&b.display.eye)));
        Ok(out)
    }

    fn parse(&self, wall: &str, row: Row) -> Result<LampReading, StoreError> {
        let utc = row.utc.parse::<Timestamp>().map_err(|e| {
            self.bad(format!(
                "a lamp reading of display {} has an unreadable time {:?}: {e}",
                row.display, row.utc
            ))
        })?;
        let eye = match row.eye.as_str() {
            "mono" => Eye::Mono,
            "left" => Eye::Left,
            "right" => Eye::Right,
            other => {
                return Err(self.bad(format!(
                    "a lamp reading of display {} has unknown eye {other:?}",
                    row.display
                )));
            }
        };
        let reading = LampReading {
            display: DisplayKey {
                wall: wall.to_string(),
                display: row.display,
                tile_col: row.tile[0],
                tile_row: row.tile[1],
                eye,
            },
            utc,
            primaries_y_cd_m2: row.primaries,
            channel_usage: row.usage,
            headroom: row.headroom,
        };
        check_reading(wall, &reading).map_err(|e| self.bad(e.to_string()))?;
        Ok(reading)
    }
}

fn read_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<Row> {
    Ok(Row {
        utc: r.get(0)?,
        display: r.get(1)?,
        eye: r.get(2)?,
        tile: [r.get(3)?, r.get(4)?],
        primaries: [r.get(5)?, r.get(6)?, r.get(7)?],
        usage: [r.get(8)?, r.get(9)?, r.get(10)?],
        headroom: r.get(11)?,
    })
}

fn insert(tx: &rusqlite::Transaction<'_>, source: &str, r: &LampReading) -> rusqlite::Result<()> {
    let [red, green, blue] = r.primaries_y_cd_m2;
    let [ur, ug, ub] = r.channel_usage;
    tx.execute(
        "INSERT INTO lamp_readings (wall, measured_utc, measured_unix_ms, display, eye,
             tile_col, tile_row, red_cd_m2, green_cd_m2, blue_cd_m2,
             usage_red, usage_green, usage_blue, headroom, source)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
        params![
            r.display.wall,
            r.utc.to_string(),
            r.utc.as_millisecond(),
            r.display.display,
            eye_text(r.display.eye),
            r.display.tile_col,
            r.display.tile_row,
            red,
            green,
            blue,
            ur,
            ug,
            ub,
            r.headroom,
            source,
        ],
    )?;
    Ok(())
}

/// A reading the forecast can use: of `wall`, positive finite luminances, usages and
/// headroom.
fn check_reading(wall: &str, r: &LampReading) -> Result<(), StoreError> {
    let bad = |what: String| {
        Err(StoreError::InvalidRun(format!(
            "lamp reading of {}: {what}",
            r.display
        )))
    };
    if r.display.wall != wall {
        return bad(format!(
            "belongs to wall {:?}, not {wall:?}",
            r.display.wall
        ));
    }
    if !r.is_usable() {
        return bad(format!(
            "luminances {:?} cd/m² must be positive, usages {:?} finite and not negative, \
             headroom {} positive",
            r.primaries_y_cd_m2, r.channel_usage, r.headroom
        ));
    }
    Ok(())
}

//! The swap barrier a node hosts for a wall whose nodes render their own tiles:
//! calls for one (group, frame) wait until `parties` of them have arrived, then all
//! return together and each node presents.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::watch;
use tonic::Status;

use crate::limits::valid_name;

/// Most nodes one barrier waits for.
pub const MAX_PARTIES: u32 = 1024;

/// Longest wait of one call.
pub const MAX_BARRIER_WAIT: Duration = Duration::from_secs(60);

/// Most frames waited for at once (a runaway client cannot grow the table).
pub const MAX_OPEN_FRAMES: usize = 4096;

/// One frame's arrivals.
struct Arrivals {
    parties: u32,
    arrived: u32,
    release: watch::Sender<bool>,
}

/// The barrier's open frames.
#[derive(Clone, Default)]
pub struct SwapBarrier {
    open: Arc<Mutex<HashMap<(String, u64), Arrivals>>>,
}

impl SwapBarrier {
    /// Waits until `parties` calls for `frame` of `group` have arrived (this one
    /// included) or `timeout` passes; returns how long it waited.
    pub async fn arrive(
        &self,
        group: &str,
        frame: u64,
        parties: u32,
        timeout: Duration,
    ) -> Result<Duration, Status> {
        check(group, parties, timeout)?;
        let started = Instant::now();
        let key = (group.to_string(), frame);
        let mut release = self.join(&key, parties)?;
        let waited = tokio::time::timeout(timeout, release.wait_for(|r| *r)).await;
        match waited {
            Ok(Ok(_)) => Ok(started.elapsed()),
            _ => {
                let missing = self.leave(&key);
                Err(Status::deadline_exceeded(format!(
                    "swap barrier of {group} frame {frame}: {missing} of {parties} nodes did \
                     not arrive within {:.1} s",
                    timeout.as_secs_f64()
                )))
            }
        }
    }

    /// Counts a call in; the last one releases everybody.
    fn join(&self, key: &(String, u64), parties: u32) -> Result<watch::Receiver<bool>, Status> {
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        if !open.contains_key(key) && open.len() >= MAX_OPEN_FRAMES {
            return Err(Status::resource_exhausted(format!(
                "the swap barrier has {MAX_OPEN_FRAMES} frames waiting; are the nodes' frame numbers in step?"
            )));
        }
        let entry = open.entry(key.clone()).or_insert_with(|| Arrivals {
            parties,
            arrived: 0,
            release: watch::channel(false).0,
        });
        if entry.parties != parties {
            return Err(Status::invalid_argument(format!(
                "swap barrier of {} frame {}: {parties} parties, but an earlier call said {}",
                key.0, key.1, entry.parties
            )));
        }
        entry.arrived += 1;
        let rx = entry.release.subscribe();
        if entry.arrived >= entry.parties {
            entry.release.send_replace(true);
            open.remove(key);
        }
        Ok(rx)
    }

    /// Counts a call that gave up out again; returns how many were still missing.
    fn leave(&self, key: &(String, u64)) -> u32 {
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        match open.get_mut(key) {
            Some(a) => {
                let missing = a.parties - a.arrived;
                a.arrived -= 1;
                if a.arrived == 0 {
                    open.remove(key);
                }
                missing
            }
            None => 0,
        }
    }
}

fn check(group: &str, parties: u32, timeout: Duration) -> Result<(), Status> {
    if !valid_name(group) {
        return Err(Status::invalid_argument(format!(
            "swap barrier group {group:?} is not a valid name (letters, digits, -_.:@)"
        )));
    }
    if !(1..=MAX_PARTIES).contains(&parties) {
        return Err(Status::invalid_argument(format!(
            "swap barrier: {parties} parties; give 1 to {MAX_PARTIES}"
        )));
    }
    if timeout.is_zero() || timeout > MAX_BARRIER_WAIT {
        return Err(Status::invalid_argument(format!(
            "swap barrier: a wait of {} ms; give 1 to {} ms",
            timeout.as_millis(),
            MAX_BARRIER_WAIT.as_millis()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn all_parties_are_released_together_once_the_last_arrives() {
        let b = SwapBarrier::default();
        let wait = Duration::from_secs(5);
        let (b1, b2) = (b.clone(), b.clone());
        let first = tokio::spawn(async move { b1.arrive("wall", 7, 3, wait).await });
        let second = tokio::spawn(async move { b2.arrive("wall", 7, 3, wait).await });
        tokio::time::sleep(Duration::from_millis(100)).await;
        assert!(
            !first.is_finished() && !second.is_finished(),
            "two of three wait"
        );
        let last = b.arrive("wall", 7, 3, wait).await.unwrap();
        assert!(
            last < Duration::from_millis(50),
            "the last one does not wait"
        );
        for h in [first, second] {
            assert!(h.await.unwrap().unwrap() >= Duration::from_millis(90));
        }
        assert!(b.open.lock().unwrap().is_empty());
    }

    #[tokio::test]
    async fn a_missing_party_times_out_naming_how_many_are_missing_and_is_counted_out() {
        let b = SwapBarrier::default();
        let e = b
            .arrive("wall", 1, 2, Duration::from_millis(50))
            .await
            .unwrap_err();
        assert_eq!(e.code(), tonic::Code::DeadlineExceeded);
        assert!(
            e.message().contains("1 of 2 nodes did not arrive"),
            "{}",
            e.message()
        );
        assert!(b.open.lock().unwrap().is_empty());
        let e = b
            .arrive("wall", 2, 0, Duration::from_secs(1))
            .await
            .unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument);
    }

    #[tokio::test]
    async fn calls_disagreeing_on_the_parties_are_refused() {
        let b = SwapBarrier::default();
        let b1 = b.clone();
        let waiting =
            tokio::spawn(async move { b1.arrive("wall", 3, 2, Duration::from_millis(300)).await });
        tokio::time::sleep(Duration::from_millis(50)).await;
        let e = b
            .arrive("wall", 3, 5, Duration::from_secs(1))
            .await
            .unwrap_err();
        assert!(
            e.message().contains("an earlier call said 2"),
            "{}",
            e.message()
        );
        assert!(waiting.await.unwrap().is_err(), "the first still times out");
    }
}

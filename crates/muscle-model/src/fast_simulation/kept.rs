//! A short list of shared, immutable results looked up by key: the per-trial store of
//! activation tables and channels.
//!
//! Lookups compare keys linearly; the list holds at most [`SHARED_CHANNELS`] items and drops
//! the oldest beyond that, which bounds the memory a long fit (a new delay or activation at
//! every step) keeps alive per trial.

use std::sync::{Arc, Mutex};

/// Activation tables and channels kept per [`crate::inputs::TrialInputs`] (each list; shared
/// by its clones and by every thread).
pub(super) const SHARED_CHANNELS: usize = 12;

/// Results shared across threads, newest last.
pub(super) struct KeptList<T>(Mutex<Vec<Arc<T>>>);

impl<T> Default for KeptList<T> {
    fn default() -> Self {
        KeptList(Mutex::new(Vec::new()))
    }
}

impl<T> KeptList<T> {
    /// Finds `key` in the list.
    pub(super) fn find<K: PartialEq>(&self, key: &K, key_of: impl Fn(&T) -> &K) -> Option<Arc<T>> {
        let list = self.0.lock().unwrap_or_else(|e| e.into_inner());
        list.iter().find(|c| key_of(c) == key).map(Arc::clone)
    }

    /// The newest item that `pred` accepts.
    pub(super) fn find_where(&self, pred: impl Fn(&T) -> bool) -> Option<Arc<T>> {
        let list = self.0.lock().unwrap_or_else(|e| e.into_inner());
        list.iter().rev().find(|c| pred(c)).map(Arc::clone)
    }

    /// Keeps `item` (unless an equal one arrived meanwhile, which is returned instead),
    /// dropping the oldest beyond [`SHARED_CHANNELS`].
    pub(super) fn keep<K: PartialEq>(&self, item: Arc<T>, key_of: impl Fn(&T) -> &K) -> Arc<T> {
        let mut list = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = list.iter().find(|c| key_of(c) == key_of(&item)) {
            return Arc::clone(c);
        }
        if list.len() >= SHARED_CHANNELS {
            list.remove(0);
        }
        list.push(Arc::clone(&item));
        item
    }
}

//! The editing sessions: one [`PoseEditor`] per page, so two pages never see each other's pins,
//! at most a fixed number open (the least recently used closed first).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

use super::error::ApiError;
use crate::edit::pose::PoseEditor;
use crate::rng::Rng;

/// One page's editing state: the editor (on the outfit the page draws), that outfit, and the
/// pins' source points it was last given (the editor rebinds only when they change, so a drag
/// continues from where the previous request left the latent).
pub(crate) struct Session {
    pub(crate) editor: PoseEditor<'static>,
    pub(crate) outfit: usize,
    pub(crate) sources: Vec<[f32; 2]>,
}

/// The open sessions, least recently used first, and the generator of their ids.
struct Open {
    ids: Rng,
    list: VecDeque<(String, Arc<Mutex<Session>>)>,
}

/// The editing sessions of a server.
pub(crate) struct Sessions {
    most: usize,
    open: Mutex<Open>,
}

/// Locks `m`; a poisoned lock (a request that panicked while holding it) is taken as it is:
/// every value behind these locks is whole between statements, so the next request may use it.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Sessions {
    /// No sessions yet; at most `most` kept open. Ids are drawn from a generator seeded by the
    /// clock (they keep pages apart, they are not secrets: the editor has no login).
    pub(crate) fn new(most: usize) -> Self {
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        Sessions {
            most,
            open: Mutex::new(Open {
                ids: Rng::new(seed),
                list: VecDeque::new(),
            }),
        }
    }

    /// How many are open.
    pub(crate) fn count(&self) -> usize {
        lock(&self.open).list.len()
    }

    /// Opens `session`, closing the least recently used beyond the limit; returns its id.
    pub(crate) fn open(&self, session: Session) -> String {
        let mut open = lock(&self.open);
        let id = format!("{:016x}", open.ids.next_u64());
        while open.list.len() >= self.most {
            open.list.pop_front();
        }
        open.list.push_back((id.clone(), Arc::new(Mutex::new(session))));
        id
    }

    /// Session `id`, now the most recently used.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown (or closed) session.
    pub(crate) fn get(&self, id: &str) -> Result<Arc<Mutex<Session>>, ApiError> {
        let open = &mut lock(&self.open).list;
        let Some(at) = open.iter().position(|(k, _)| k == id) else {
            return Err(ApiError::not_found(
                "no such editing session (it may have been closed for a newer one): pick a frame again",
            ));
        };
        // Most recently used last: the next eviction spares it.
        let entry = open.remove(at).expect("position found above");
        let session = entry.1.clone();
        open.push_back(entry);
        Ok(session)
    }
}

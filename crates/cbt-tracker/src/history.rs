//! The learning history: the last two frames' states, which chain online learning's frames
//! into transitions and triples ([`CbtModel::add_frame`](crate::CbtModel)). It is part of a
//! tracker's state: a tracker saved and loaded must chain its next frame to the same two.

use serde::{Deserialize, Serialize};

use crate::encode::{Encoded, encode_states};
use crate::{Point, Space, TrackError};

/// The encodings of the last two frames' states (`prev`: the last frame, possibly without
/// states; `prev2`: the one before, kept only when it had states) and the states they encode.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct History {
    prev: Option<Encoded>,
    prev2: Option<Encoded>,
    /// The states `prev` and `prev2` encode (what a saved tracker stores).
    states: Saved,
}

/// A [`History`] as saved: the states of its two frames. Their encodings are recomputed on
/// loading (encoding is deterministic, so they are bit-identical), which also validates them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct Saved {
    prev: Option<Vec<Point>>,
    prev2: Option<Vec<Point>>,
}

impl History {
    /// Takes the last two frames' encodings, each only when it had states (`prev` is left
    /// empty until [`push`](Self::push)).
    pub fn take(&mut self) -> (Option<Encoded>, Option<Encoded>) {
        let prev = self.prev.take().filter(|p| !p.is_empty());
        let prev2 = self.prev2.take().filter(|p| !p.is_empty());
        (prev, prev2)
    }

    /// Records a new frame with `states`, encoded as `x`, after `prev` (what
    /// [`take`](Self::take) returned as the last frame).
    pub fn push(&mut self, states: &[Point], x: Encoded, prev: Option<Encoded>) {
        let prev_states = self.states.prev.take();
        self.states = Saved {
            prev: Some(states.to_vec()),
            prev2: prev.is_some().then_some(prev_states).flatten(),
        };
        self.prev2 = prev;
        self.prev = Some(x);
    }

    /// What a saved tracker stores.
    pub fn saved(&self) -> &Saved {
        &self.states
    }

    /// The history of a loaded tracker: `saved`'s states encoded on `space` with `weight`
    /// (the online weight) as [`CbtModel::add_frame`](crate::CbtModel) encodes them; a state
    /// off the grid or not finite is a [`TrackError::Corrupt`].
    pub fn restore(
        saved: Saved,
        space: &Space,
        weight: f64,
        joint: bool,
    ) -> Result<History, TrackError> {
        let enc = |s: &Option<Vec<Point>>| -> Result<Option<Encoded>, TrackError> {
            s.as_ref()
                .map(|s| encode_states(space, s, weight, joint))
                .transpose()
                .map_err(|e| TrackError::Corrupt(format!("learning history: {e}")))
        };
        Ok(History {
            prev: enc(&saved.prev)?,
            prev2: enc(&saved.prev2)?,
            states: saved,
        })
    }
}

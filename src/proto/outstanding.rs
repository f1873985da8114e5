//! Which request an answer answers.
//!
//! The robot echoes each request's message ID in the answer's header, so a client may write
//! several requests without waiting and match the answers by ID, in whatever order they
//! come. One exception: a Type 0 answer (request error) to a frame whose header the robot
//! could not read carries no ID the robot could know. A Type 0 answer whose ID matches no
//! outstanding request therefore answers the **oldest** one, the first the robot read.
//! Any other frame answers the request with its ID only if it has that request's Type (as
//! the caller tells): a robot's own report of another Type that reuses the ID is none of
//! its answers.
//!
//! [`Outstanding`] is that rule, for one connection: the firmware's client, `x30ctl` and
//! the simulator's tests all match answers with it.

use heapless::Vec;

/// The requests written on one connection and not answered yet, oldest first, each with
/// what the caller wants to remember of it (`T`: its Type, when it went out, …).
#[derive(Debug, Clone)]
pub struct Outstanding<T, const N: usize> {
    /// `(message ID, remembered)` in the order written.
    requests: Vec<(u16, T), N>,
}

impl<T, const N: usize> Outstanding<T, N> {
    /// Nothing outstanding.
    pub const fn new() -> Self {
        Self {
            requests: Vec::new(),
        }
    }

    /// Notes a request written with `message_id`. With `N` already outstanding the oldest is
    /// given up on to make room, and returned: its answer, if it ever comes, is unsolicited.
    pub fn push(&mut self, message_id: u16, request: T) -> Option<(u16, T)> {
        let evicted = if self.requests.is_full() {
            self.pop_oldest()
        } else {
            None
        };
        // Room was made above, so this cannot fail; the result is ignored rather than unwrapped.
        let _ = self.requests.push((message_id, request));
        evicted
    }

    /// Takes out the request an answer with `message_id` answers: the one with that ID, or,
    /// for a Type 0 answer (`request_error`) whose ID matches none, the oldest. `None`: the
    /// answer is unsolicited (late, after the request was given up on, or never asked for).
    pub fn answer(&mut self, message_id: u16, request_error: bool) -> Option<(u16, T)> {
        self.answer_if(message_id, request_error, |_| true)
    }

    /// [`Outstanding::answer`] for a frame that answers the request with its ID only if
    /// `answers` holds for that request (the frame has its Type); a Type 0 answer answers it
    /// regardless. `None`: the frame answers nothing, and the request stays outstanding.
    pub fn answer_if(
        &mut self,
        message_id: u16,
        request_error: bool,
        answers: impl FnOnce(&T) -> bool,
    ) -> Option<(u16, T)> {
        match self.position(message_id) {
            Some(at) if request_error || self.requests.get(at).is_some_and(|(_, r)| answers(r)) => {
                Some(self.requests.remove(at))
            }
            Some(_) => None,
            None if request_error => self.pop_oldest(),
            None => None,
        }
    }

    /// Gives up on the request with `message_id`; what was remembered of it, if it was
    /// outstanding.
    pub fn remove(&mut self, message_id: u16) -> Option<T> {
        let at = self.position(message_id)?;
        Some(self.requests.remove(at).1)
    }

    /// The oldest request still waiting for its answer.
    pub fn oldest(&self) -> Option<&(u16, T)> {
        self.requests.first()
    }

    /// The requests waiting for their answers, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &(u16, T)> {
        self.requests.iter()
    }

    /// Gives up on the oldest request and returns it.
    pub fn pop_oldest(&mut self) -> Option<(u16, T)> {
        // `remove` shifts the rest down (at most `N`, a handful); it cannot fail here.
        (!self.requests.is_empty()).then(|| self.requests.remove(0))
    }

    /// What was remembered of the request with `message_id`, if it is outstanding.
    pub fn get(&self, message_id: u16) -> Option<&T> {
        let at = self.position(message_id)?;
        self.requests.get(at).map(|(_, request)| request)
    }

    /// Whether a request with `message_id` is outstanding.
    pub fn contains(&self, message_id: u16) -> bool {
        self.position(message_id).is_some()
    }

    /// How many requests are outstanding.
    pub fn len(&self) -> usize {
        self.requests.len()
    }

    /// Whether no request is outstanding.
    pub fn is_empty(&self) -> bool {
        self.requests.is_empty()
    }

    /// Forgets every request, when the connection is gone.
    pub fn clear(&mut self) {
        self.requests.clear();
    }

    /// Where the request with `message_id` stands, oldest first.
    fn position(&self, message_id: u16) -> Option<usize> {
        self.requests.iter().position(|(id, _)| *id == message_id)
    }
}

impl<T, const N: usize> Default for Outstanding<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

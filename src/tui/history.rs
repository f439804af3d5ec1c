//! Undo and redo as commands: each record keeps the commands that were applied and those that
//! undo them exactly ([`crate::session::Command::apply`] returns each inverse), so undo restores
//! the lights bit for bit without snapshots. A group edit (several lights at once) is one record
//! of several commands.

use std::collections::VecDeque;

use crate::session::Command;

/// Most edits kept for undo; older ones are forgotten.
pub const UNDO_LIMIT: usize = 1000;

/// One edit: of one light, or of a group of lights at once.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    /// Index of the light that was selected (selected again on undo and redo).
    pub light: usize,
    /// The commands that made the edit, in the order they were applied.
    pub forward: Vec<Command>,
    /// The commands that undo it, in the order to apply them (the inverses, last first).
    pub inverse: Vec<Command>,
}

impl Change {
    /// The record of one command and its inverse.
    pub fn single(light: usize, forward: Command, inverse: Command) -> Self {
        Change {
            light,
            forward: vec![forward],
            inverse: vec![inverse],
        }
    }
}

/// The undo and redo stacks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct History {
    undo: VecDeque<Change>,
    redo: Vec<Change>,
}

impl History {
    /// Records a new edit; clears the redo stack.
    pub fn record(&mut self, change: Change) {
        self.redo.clear();
        if self.undo.len() == UNDO_LIMIT {
            self.undo.pop_front();
        }
        self.undo.push_back(change);
    }

    /// Takes the latest edit to undo (it moves to the redo stack).
    pub fn undo(&mut self) -> Option<&Change> {
        let change = self.undo.pop_back()?;
        self.redo.push(change);
        self.redo.last()
    }

    /// Takes the latest undone edit to redo (it moves back to the undo stack).
    pub fn redo(&mut self) -> Option<&Change> {
        let change = self.redo.pop()?;
        self.undo.push_back(change);
        self.undo.back()
    }

    /// Number of edits that can be undone.
    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    /// Number of edits that can be redone.
    pub fn redo_len(&self) -> usize {
        self.redo.len()
    }
}

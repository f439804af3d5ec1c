//! Undo and redo as commands: each record keeps the command that was applied and the one that
//! undoes it exactly ([`crate::session::Command::apply`] returns it), so undo restores the
//! light bit for bit without snapshots.

use std::collections::VecDeque;

use crate::session::Command;

/// Most edits kept for undo; older ones are forgotten.
pub const UNDO_LIMIT: usize = 1000;

/// One edit of one light.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    /// Index of the edited light (selected again on undo and redo).
    pub light: usize,
    /// The command that made the edit.
    pub forward: Command,
    /// The command that undoes it.
    pub inverse: Command,
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

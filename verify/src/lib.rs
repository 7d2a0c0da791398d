//! Proves properties of a mission net before anything flies: deadlock
//! freedom, termination, 1-safety, dead actions, drone conflicts and
//! conditions that can never or always hold.

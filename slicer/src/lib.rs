//! Partitions a mission net into one slice per drone (and the ground
//! station). Every place and transition goes to exactly one owner; an arc
//! between two owners becomes a bridge, the only thing that crosses between
//! drones at run time.

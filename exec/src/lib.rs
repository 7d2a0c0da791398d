//! The token-passing executor: runs one slice on one drone, starting actions
//! through the middle layer and passing tokens over bridges (in-process
//! channels or zenoh).

pub mod transport;

pub mod mavlink;
pub mod rollout;

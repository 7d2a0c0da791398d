pub mod mavlink;

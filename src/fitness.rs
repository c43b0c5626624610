//! TODO: fitness stage (being written).

//! TODO: monitor stage (being written).

//! TODO: conditioning stage (being written).

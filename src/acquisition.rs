//! TODO: acquisition stage (being written).

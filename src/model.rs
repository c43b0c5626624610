//! TODO: model stage (being written).

//! TODO: health stage (being written).

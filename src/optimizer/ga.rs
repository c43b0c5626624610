//! TODO: ga (being written).

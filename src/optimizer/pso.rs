//! TODO: pso (being written).

//! Channel representation (placeholder while being written).

//! `pvrsim scene`: writes a fitted scene (placeholder removed below).

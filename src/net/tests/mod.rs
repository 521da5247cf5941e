//! Tests of the `net` module, one file per concern.

mod codec;
mod cost;
mod protocols;
mod sim;
mod transport;

//! The AFL++ entry point of the decoder target alone (no polars in the build), for CI's
//! bounded run: `afl_decoder`, reading AFL's inputs in persistent mode.

#[path = "../decoder.rs"]
mod decoder;

fn main() {
    afl::fuzz!(|data: &[u8]| {
        decoder::run(data);
    });
}

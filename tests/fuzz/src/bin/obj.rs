//! Fuzz target `obj`: see [`caoen_fuzz::obj`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::obj(data);
    });
}

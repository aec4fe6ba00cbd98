//! Fuzz target `scene_frep`: see [`caoen_fuzz::scene`].
#![forbid(unsafe_code)]

fn main() {
    afl::fuzz!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::scene(data);
    });
}

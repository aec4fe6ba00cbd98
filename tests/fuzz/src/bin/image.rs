//! Fuzz target `image`: see [`caoen_fuzz::image`].
#![forbid(unsafe_code)]

fn main() {
    // Without the hook: `image_io` turns a panic inside a third-party image decoder into
    // an error on purpose, and the hook would abort on it before it is caught. A panic
    // that escapes still aborts.
    afl::fuzz_nohook!(|data: &[u8]| {
        caoen_fuzz::single_thread();
        let _ = caoen_fuzz::image(data);
    });
}

#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| visguide_fuzz::tracking_mot(data));

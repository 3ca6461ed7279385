#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| visguide_fuzz::lwpr_xml(data));

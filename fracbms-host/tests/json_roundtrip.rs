//! A fit's JSON read back: every number is the `f64` that wrote it.

use fracbms_host::identify::battery::read_json_file;

/// A fit's number written to JSON is read back as the same `f64`, so a
/// prior or a map taken from a fit's JSON is that fit to the bit. Without
/// serde_json's `float_roundtrip` the first value (a fit's U_oc) came back
/// one ulp off, 3.651384436973741.
#[test]
fn a_json_number_reads_back_to_the_bit() {
    let path = std::env::temp_dir().join(format!("fracbms-roundtrip-{}.json", std::process::id()));
    for x in [3.6513844369737405_f64, 0.1 + 0.2, 1e-300, 5.558009e-3] {
        std::fs::write(&path, serde_json::json!({ "u_oc": x }).to_string()).unwrap();
        let j = read_json_file(&path).unwrap();
        assert_eq!(j["u_oc"].as_f64().unwrap().to_bits(), x.to_bits(), "{x:e}");
    }
    std::fs::remove_file(&path).ok();
}

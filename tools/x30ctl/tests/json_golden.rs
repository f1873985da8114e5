//! The JSON output, byte for byte: `decode --json --xml` of a capture holding every request
//! and answer kind (tests/golden/capture.hex) must print exactly tests/golden/decode.jsonl.
//!
//! Every answer a command prints with `--json` goes through the same serialisation as an
//! answer found by `decode`, so this pins the field names, their order, the float text and
//! the code objects of all of them. Scripts parse this output; a change here breaks them.

mod common;

use common::x30ctl_raw;

#[test]
fn decode_json_matches_the_recorded_output_byte_for_byte() {
    let capture = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/capture.hex");
    let expected = include_str!("golden/decode.jsonl");
    let run = x30ctl_raw(&["decode", "--json", "--xml", capture]);
    run.expect_code(0);
    // Line by line first, so a failure names the first frame that differs.
    for (number, (got, want)) in run.stdout.lines().zip(expected.lines()).enumerate() {
        assert_eq!(got, want, "line {} differs", number + 1);
    }
    assert_eq!(run.stdout, expected);
}

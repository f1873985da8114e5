//! Every codec error prints a message naming what was wrong, and is a `std::error::Error`.

use x30_panel::proto::frame::FrameError;
use x30_panel::proto::message::{DecodeError, Response, ValidationError};
use x30_panel::proto::xml::number::NumberError;
use x30_panel::proto::xml::writer::{ItemName, WriteError};

#[test]
fn decode_errors_name_the_item_and_the_problem() {
    let xml = "<PatrolDevice><Type>2002</Type><Command>1</Command><Items><ObsState>x</ObsState></Items></PatrolDevice>";
    let err = Response::decode(xml.as_bytes()).unwrap_err();
    assert_eq!(err.to_string(), "item <ObsState>: not a decimal number");
    assert_eq!(
        DecodeError::MissingItem(ItemName::new("PosX")).to_string(),
        "item <PosX> is missing"
    );
    assert_eq!(
        DecodeError::UnknownType(2102).to_string(),
        "unknown Type 2102"
    );
    let xml = "<PatrolDevice><Type>1</Typo></PatrolDevice>";
    assert_eq!(
        Response::decode(xml.as_bytes()).unwrap_err().to_string(),
        "XML: end tag does not match the open element at byte 21"
    );
}

#[test]
fn other_errors_print_their_details() {
    assert_eq!(
        FrameError::TooLong {
            message_id: 7,
            asdu_len: 5000
        }
        .to_string(),
        "message 7: 5000-byte body is too long, skipped"
    );
    assert_eq!(
        WriteError::NotFinite {
            item: ItemName::new("PosX")
        }
        .to_string(),
        "item <PosX> is NaN or infinite"
    );
    assert_eq!(
        ValidationError::SpeedOutOfRange { max: 1.5 }.to_string(),
        "speed must be -1 or 0..=1.5"
    );
    assert_eq!(NumberError::OutOfRange.to_string(), "number out of range");
}

#[test]
fn errors_pass_through_question_mark_into_box_dyn_error() {
    fn decode(xml: &str) -> Result<Response, Box<dyn std::error::Error>> {
        Ok(Response::decode(xml.as_bytes())?.message)
    }
    assert!(decode("nonsense").is_err());
}

#[test]
fn item_names_print_as_their_text() {
    // The longest item name the protocol has.
    const NAME: ItemName = ItemName::new("BatteryTemperature");
    assert_eq!(NAME.as_bytes(), b"BatteryTemperature");
    assert_eq!(NAME.to_string(), "BatteryTemperature");
    assert_eq!(format!("{NAME:?}"), "\"BatteryTemperature\"");
    assert_eq!(
        format!("{:?}", DecodeError::MissingItem(NAME)),
        "MissingItem(\"BatteryTemperature\")"
    );
}

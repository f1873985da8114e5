//! The `Time` element.

use x30_panel::proto::time::{TIME_TEXT_LEN, Timestamp};

#[test]
fn encodes_and_decodes() {
    let t = Timestamp {
        year: 2024,
        month: 11,
        day: 19,
        hour: 8,
        minute: 5,
        second: 9,
    };
    let mut text = [0u8; TIME_TEXT_LEN];
    t.encode(&mut text);
    assert_eq!(&text, b"2024-11-19 08:05:09");
    assert_eq!(Timestamp::decode(&text), Ok(t));
    assert_eq!(
        Timestamp::decode(b"0000-00-00 00:00:00"),
        Ok(Timestamp::ZERO)
    );
}

#[test]
fn rejects_other_shapes() {
    for bad in [
        &b"2024-11-19T08:05:09"[..],
        b"2024-11-19 08:05",
        b"2024/11/19 08:05:09",
        b"20x4-11-19 08:05:09",
        b"",
        b"2024-11-19 08:05:09 ",
    ] {
        assert!(
            Timestamp::decode(bad).is_err(),
            "{}",
            String::from_utf8_lossy(bad)
        );
    }
}

/// Each byte is checked at its own place: changing any one byte of a valid time to any
/// other value is refused unless it puts a digit where a digit belongs, and then exactly
/// that field changes.
#[test]
fn checks_every_byte_at_its_place() {
    let good = *b"9876-54-32 10:98:76";
    let fields = |text: &[u8]| {
        let s = std::str::from_utf8(text).unwrap();
        [
            &s[0..4],
            &s[5..7],
            &s[8..10],
            &s[11..13],
            &s[14..16],
            &s[17..19],
        ]
        .map(|f| f.parse::<u16>().unwrap())
    };
    let read = |t: Timestamp| {
        [
            t.year,
            t.month.into(),
            t.day.into(),
            t.hour.into(),
            t.minute.into(),
            t.second.into(),
        ]
    };
    assert_eq!(read(Timestamp::decode(&good).unwrap()), fields(&good));
    for at in 0..TIME_TEXT_LEN {
        for byte in 0..=255u8 {
            let mut text = good;
            text[at] = byte;
            let separator = [4, 7, 10, 13, 16].contains(&at);
            let acceptable = byte == good[at] || (!separator && byte.is_ascii_digit());
            match Timestamp::decode(&text) {
                Ok(t) => {
                    assert!(acceptable, "accepted {:?}", String::from_utf8_lossy(&text));
                    assert_eq!(read(t), fields(&text));
                }
                Err(_) => assert!(!acceptable, "refused {:?}", String::from_utf8_lossy(&text)),
            }
        }
    }
}

#[test]
fn counts_on_across_days_months_and_leap_years() {
    let t = Timestamp {
        year: 2023,
        month: 12,
        day: 31,
        hour: 23,
        minute: 59,
        second: 58,
    };
    assert_eq!(
        t.plus_seconds(3),
        Timestamp {
            year: 2024,
            month: 1,
            day: 1,
            hour: 0,
            minute: 0,
            second: 1
        }
    );
    let feb = Timestamp {
        year: 2024,
        month: 2,
        day: 28,
        hour: 12,
        minute: 0,
        second: 0,
    };
    assert_eq!(feb.plus_seconds(86_400), Timestamp { day: 29, ..feb });
    assert_eq!(
        feb.plus_seconds(2 * 86_400),
        Timestamp {
            month: 3,
            day: 1,
            ..feb
        }
    );
    let feb_2023 = Timestamp { year: 2023, ..feb };
    assert_eq!(
        feb_2023.plus_seconds(86_400),
        Timestamp {
            month: 3,
            day: 1,
            ..feb_2023
        }
    );
    assert_eq!(t.plus_seconds(0), t);
    // 400 days from the document's epoch.
    let later = Timestamp::DOCUMENT_EPOCH.plus_seconds(400 * 86_400 + 3_661);
    assert_eq!(
        later,
        Timestamp {
            year: 2024,
            month: 2,
            day: 5,
            hour: 1,
            minute: 1,
            second: 1
        }
    );
}

#[test]
fn zero_time_counts_from_the_document_epoch() {
    assert_eq!(
        Timestamp::ZERO.plus_seconds(61),
        Timestamp {
            minute: 1,
            second: 1,
            ..Timestamp::DOCUMENT_EPOCH
        }
    );
}

/// Every value of every field is written as `format!` writes its last digits: four for the
/// year, two for the others.
#[test]
fn encodes_every_field_value_as_its_last_digits() {
    let text = |t: &Timestamp| {
        let mut text = [0u8; TIME_TEXT_LEN];
        t.encode(&mut text);
        String::from_utf8(text.to_vec()).unwrap()
    };
    let expected = |t: &Timestamp| {
        format!(
            "{:04}-{:02}-{:02} {:02}:{:02}:{:02}",
            t.year % 10_000,
            t.month % 100,
            t.day % 100,
            t.hour % 100,
            t.minute % 100,
            t.second % 100
        )
    };
    for year in 0..=u16::MAX {
        let t = Timestamp {
            year,
            ..Timestamp::DOCUMENT_EPOCH
        };
        assert_eq!(text(&t), expected(&t));
    }
    for v in 0..=u8::MAX {
        for t in [
            Timestamp {
                month: v,
                ..Timestamp::ZERO
            },
            Timestamp {
                day: v,
                ..Timestamp::ZERO
            },
            Timestamp {
                hour: v,
                ..Timestamp::ZERO
            },
            Timestamp {
                minute: v,
                ..Timestamp::ZERO
            },
            Timestamp {
                second: v,
                ..Timestamp::ZERO
            },
        ] {
            assert_eq!(text(&t), expected(&t));
        }
    }
}

//! What the XML reader tolerates (docs/protocol.md, "XML body" and "Beyond the document")
//! and what it rejects, each with a typed error.

use x30_panel::proto::message::{DecodeError, Request, Response};
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::reader::{MAX_DEPTH, Token, Tokenizer, XmlErrorKind};
use x30_panel::proto::xml::writer::ItemName;
use x30_panel::proto::xml::{StructureError, read_document};

const BODY: &str = "<PatrolDevice><Type>2002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><ObsState>1</ObsState></Items></PatrolDevice>";

fn obstacle(xml: &str) -> Result<Response, DecodeError> {
    Response::decode(xml.as_bytes()).map(|d| d.message)
}

fn assert_obstacle(xml: &str) {
    use x30_panel::proto::codes::ObsState;
    use x30_panel::proto::message::Perception;
    assert_eq!(
        obstacle(xml),
        Ok(Response::Perception(Perception {
            obs_state: ObsState::ObstacleAhead
        })),
        "{xml}"
    );
}

fn xml_error(xml: &str) -> XmlErrorKind {
    match obstacle(xml) {
        Err(DecodeError::Structure(StructureError::Xml(e))) => e.kind,
        other => panic!("expected an XML error for {xml}, got {other:?}"),
    }
}

#[test]
fn declaration_styles_and_none() {
    for decl in [
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>",
        "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>",
        "<?xml version='1.0' encoding='utf-8'?>",
        "",
        "\u{feff}<?xml version=\"1.0\"?>",
    ] {
        assert_obstacle(&format!("{decl}\n{BODY}"));
    }
}

/// The shortcut for the document's start (a declaration, whitespace, `<PatrolDevice>`)
/// gives exactly what the general path gives for every start it takes or declines:
/// the usual ones, and ones it must leave to the general path (two declarations, a comment,
/// a form feed, an unclosed declaration, attributes, another root, an empty root).
#[test]
fn document_starts_read_alike_by_both_paths() {
    let body = BODY.trim_start_matches("<PatrolDevice>");
    for start in [
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>",
        "<PatrolDevice>",
        "\n \t<PatrolDevice>",
        "<??><PatrolDevice>",
        "<?xml?><?other?>\n<PatrolDevice>",
        "<?xml?><!-- c --><PatrolDevice>",
        "<?xml?>\x0c<PatrolDevice>",
        "<?xml <PatrolDevice>",
        "<?xml?><PatrolDevice a=\"1\">",
        "<?xml?><PatrolDevice >",
        "<?xml?><PatrolDevices>",
        "<?xml?><PatrolDevice/>",
        "<?xml?><Other>",
        "<?xml?>text<PatrolDevice>",
        "<?xml?>",
    ] {
        let document = format!("{start}{body}");
        assert_read_alike(&document);
    }
    assert_obstacle(&format!("<?xml?>\n<PatrolDevice>{body}"));
}

/// The shortcut for the header lines real documents write (`Type`, `Command`, `Time`, in
/// that order, each value read in the pass that finds its end) gives exactly what the
/// general path gives, for the lines it takes and for the ones it must leave to the
/// general path: whitespace around a value, a sign, a value that does not parse or does
/// not fit, a time one byte too short or too long, another order, a repeated element, a
/// name in other case.
#[test]
fn header_lines_read_alike_by_both_paths() {
    let usual = [
        "<Type>2002</Type>",
        "<Command>1</Command>",
        "<Time>2023-01-01 00:00:00</Time>",
    ];
    let variants: [[&str; 3]; 14] = [
        usual,
        ["<Type> 2002 </Type>", usual[1], usual[2]],
        ["<Type>+2002</Type>", "<Command>-1</Command>", usual[2]],
        ["<Type>20O2</Type>", usual[1], usual[2]],
        ["<Type>2147483648</Type>", usual[1], usual[2]],
        ["<Type></Type>", usual[1], usual[2]],
        [usual[0], usual[1], "<Time>2023-01-01 00:00:0</Time>"],
        [usual[0], usual[1], "<Time>2023-01-01 00:00:000</Time>"],
        [usual[0], usual[1], "<Time> 2023-01-01 00:00:00\n</Time>"],
        [usual[0], usual[1], "<Time>2023-01-01T00:00:00</Time>"],
        [usual[2], usual[1], usual[0]],
        [usual[1], usual[0], usual[0]],
        ["<Type>1</Type>", usual[0], usual[1]],
        ["<type>2002</type>", usual[1], usual[2]],
    ];
    for [a, b, c] in variants {
        let document = format!(
            "<PatrolDevice>\n  {a}\n  {b}\n  {c}\n  <Items><ObsState>1</ObsState></Items>\n</PatrolDevice>"
        );
        assert_read_alike(&document);
    }
    assert_obstacle(&format!(
        "<PatrolDevice>\n  {}\n  {}\n  {}\n  <Items><ObsState>1</ObsState></Items>\n</PatrolDevice>",
        usual[0], usual[1], usual[2]
    ));
}

#[test]
fn any_whitespace_and_comments() {
    assert_obstacle(&BODY.replace("><", ">\n\t\t<"));
    assert_obstacle(&BODY.replace("><", ">\r\n  <"));
    assert_obstacle(&format!(
        "<!-- before -->{}<!-- after -->\n",
        BODY.replace("<Items>", "<Items><!-- inside <Items> -->")
    ));
    assert_obstacle(&BODY.replace("<ObsState>1</ObsState>", "<ObsState>\n   1\t</ObsState>"));
    assert_obstacle(&BODY.replace("<ObsState>1</ObsState>", "<ObsState><!-- c -->1</ObsState>"));
    assert_obstacle(&BODY.replace("</ObsState>", "</ObsState >"));
}

#[test]
fn elements_in_any_order_and_unknown_ones_skipped() {
    let reordered = "<PatrolDevice><Items><Extra><Deep>1</Deep></Extra><ObsState>1</ObsState><Unknown/></Items><Time>2023-01-01 00:00:00</Time><Vendor a='1'>x</Vendor><Command>1</Command><Type>2002</Type></PatrolDevice>";
    assert_obstacle(reordered);
    let mut seen = Vec::new();
    let (envelope, blocks) = read_document(reordered.as_bytes(), |envelope, items| {
        seen.push((envelope.message_type, items.count()));
        Ok::<_, StructureError>(())
    })
    .unwrap();
    assert_eq!(
        (envelope.message_type, envelope.command, blocks),
        (2002, 1, 1)
    );
    // The block came before Type, so it was read once Type was known: three items.
    assert_eq!(seen, vec![(2002, 3)]);
}

#[test]
fn self_closing_items_and_attributes() {
    let xml = "<PatrolDevice version=\"2\"><Type>1002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items /></PatrolDevice>";
    assert_eq!(
        Request::decode(xml.as_bytes()).unwrap().message,
        Request::Status
    );
}

#[test]
fn rejects_dtd_and_entity_declarations() {
    let dtd = format!("<?xml version=\"1.0\"?><!DOCTYPE PatrolDevice [<!ENTITY x \"1\">]>{BODY}");
    assert_eq!(xml_error(&dtd), XmlErrorKind::Dtd);
    assert_eq!(
        xml_error(&format!("<!ENTITY x \"1\">{BODY}")),
        XmlErrorKind::Dtd
    );
    assert_eq!(
        xml_error(&BODY.replace(">1</ObsState>", ">&x;</ObsState>")),
        XmlErrorKind::UnknownEntity
    );
    assert_eq!(
        xml_error(&BODY.replace(">1</ObsState>", "><![CDATA[1]]></ObsState>")),
        XmlErrorKind::Cdata
    );
}

#[test]
fn predefined_entities_are_well_formed_but_not_numbers() {
    let amp = BODY.replace(">1</ObsState>", ">&amp;</ObsState>");
    assert!(matches!(
        obstacle(&amp),
        Err(DecodeError::BadItem { item, .. }) if item.as_bytes() == b"ObsState"
    ));
    let unknown_item = BODY.replace("<ObsState>", "<Note>a &lt; b &#65; &#x42;</Note><ObsState>");
    assert_obstacle(&unknown_item);
}

#[test]
fn rejects_mismatched_tags() {
    assert_eq!(
        xml_error(&BODY.replace("</ObsState>", "</ObsStat>")),
        XmlErrorKind::MismatchedTag
    );
    assert_eq!(
        xml_error(&BODY.replace("</Items>", "")),
        XmlErrorKind::MismatchedTag
    );
    assert_eq!(
        xml_error(&BODY.replace("</PatrolDevice>", "")),
        XmlErrorKind::UnexpectedEnd
    );
}

/// The robot does not act on `Time`: one it cannot read costs the time (read as the all-zero
/// one of a body without `Time`, which the clock ignores), not the message.
#[test]
fn an_unreadable_time_reads_as_none_and_keeps_the_message() {
    for time in [
        "yesterday",
        "",
        "2023-01-01T00:00:00",
        "2023-01-01 00:00:00.250",
        "2023-1-1 0:0:0",
    ] {
        let xml = BODY.replace("2023-01-01 00:00:00", time);
        assert_obstacle(&xml);
        for decoded in [
            Response::decode(xml.as_bytes()),
            Response::decode_general(xml.as_bytes()),
        ] {
            assert_eq!(decoded.map(|d| d.time), Ok(Timestamp::default()), "{xml}");
        }
    }
}

#[test]
fn rejects_trailing_garbage() {
    assert_eq!(
        xml_error(&format!("{BODY}junk")),
        XmlErrorKind::TrailingContent
    );
    assert_eq!(
        xml_error(&format!("{BODY}<PatrolDevice/>")),
        XmlErrorKind::TrailingContent
    );
    assert_eq!(
        xml_error(&format!("junk{BODY}")),
        XmlErrorKind::TextOutsideRoot
    );
    // Whitespace and comments after the root are fine.
    assert_obstacle(&format!("{BODY}\n\n<!-- end -->\n"));
    // So are NUL bytes at the very end (a C string's terminator counted in the length),
    // but not before anything else.
    assert_obstacle(&format!("{BODY}\0"));
    assert_obstacle(&format!("{BODY}\n\0\0\0"));
    assert_eq!(
        xml_error(&format!("{BODY}\0\n")),
        XmlErrorKind::TrailingContent
    );
}

#[test]
fn rejects_nesting_deeper_than_the_protocol_needs() {
    let deep = BODY.replace(
        "<ObsState>1</ObsState>",
        "<ObsState>1</ObsState><A><B><C>1</C></B></A>",
    );
    assert_eq!(xml_error(&deep), XmlErrorKind::TooDeep);
    let ok = BODY.replace(
        "<ObsState>1</ObsState>",
        "<ObsState>1</ObsState><A><B>1</B></A>",
    );
    assert_obstacle(&ok);
    assert_eq!(MAX_DEPTH, 4);
}

#[test]
fn rejects_malformed_markup() {
    for (bad, kind) in [
        ("<PatrolDevice", XmlErrorKind::UnexpectedEnd),
        (
            "<PatrolDevice><Type>1002</Type",
            XmlErrorKind::UnexpectedEnd,
        ),
        ("<PatrolDevice><!-- open", XmlErrorKind::UnexpectedEnd),
        (
            "<PatrolDevice a=1></PatrolDevice>",
            XmlErrorKind::MalformedTag,
        ),
        (
            "<PatrolDevice a=\"1\"b=\"2\"></PatrolDevice>",
            XmlErrorKind::MalformedTag,
        ),
        (
            "<PatrolDevice><></></PatrolDevice>",
            XmlErrorKind::MalformedTag,
        ),
        (
            "<PatrolDevice><!foo></PatrolDevice>",
            XmlErrorKind::MalformedTag,
        ),
        ("", XmlErrorKind::NoRoot),
        ("   <!-- only a comment -->", XmlErrorKind::NoRoot),
    ] {
        let got = match Response::decode(bad.as_bytes()) {
            Err(DecodeError::Structure(StructureError::Xml(e))) => e.kind,
            other => panic!("{bad}: {other:?}"),
        };
        assert_eq!(got, kind, "{bad}");
    }
}

#[test]
fn errors_carry_the_offset() {
    let xml = "<PatrolDevice><Type>1</Typo></PatrolDevice>";
    let Err(DecodeError::Structure(StructureError::Xml(e))) = Response::decode(xml.as_bytes())
    else {
        panic!()
    };
    assert_eq!(e.kind, XmlErrorKind::MismatchedTag);
    assert_eq!(e.offset, xml.find("</Typo>").unwrap());
}

#[test]
fn wrong_root_and_missing_header_elements() {
    assert_eq!(
        obstacle("<Robot><Type>2002</Type></Robot>"),
        Err(DecodeError::Structure(StructureError::NotPatrolDevice))
    );
    assert_eq!(
        obstacle("<PatrolDevice><Command>1</Command><Items/></PatrolDevice>"),
        Err(DecodeError::Structure(StructureError::MissingElement(
            "Type"
        )))
    );
    assert_eq!(
        obstacle("<PatrolDevice><Type>2002</Type><Items/></PatrolDevice>"),
        Err(DecodeError::Structure(StructureError::MissingElement(
            "Command"
        )))
    );
    assert!(matches!(
        obstacle(&BODY.replace("<Type>2002</Type>", "<Type>x</Type>")),
        Err(DecodeError::Structure(StructureError::BadNumber("Type", _)))
    ));
    assert_eq!(
        obstacle(&BODY.replace("<ObsState>1</ObsState>", "<ObsState><X>1</X></ObsState>")),
        Err(DecodeError::ItemNotText(ItemName::new("ObsState")))
    );
}

/// `Type` or `Command` there twice with different values is refused, wherever the second
/// stands (a block read as the first would otherwise be taken for the second's); the same
/// value twice is read.
#[test]
fn a_type_or_command_declared_twice_differently_is_refused() {
    let second_type = BODY.replace("</Items>", "</Items><Type>2001</Type>");
    let second_command = BODY.replace("<Items>", "<Command>2</Command><Items>");
    let before_header = BODY.replace(
        "<Type>2002</Type><Command>1</Command>",
        "<Command>1</Command><Type>2002</Type><Command>3</Command>",
    );
    for decode in [Response::decode, Response::decode_general] {
        let decode = |xml: &str| decode(xml.as_bytes()).map(|d| d.message);
        assert_eq!(
            decode(&second_type),
            Err(DecodeError::Structure(StructureError::Conflicting("Type")))
        );
        assert_eq!(
            decode(&second_command),
            Err(DecodeError::Structure(StructureError::Conflicting(
                "Command"
            )))
        );
        assert_eq!(
            decode(&before_header),
            Err(DecodeError::Structure(StructureError::Conflicting(
                "Command"
            )))
        );
        assert_eq!(
            decode(&BODY.replace("</Items>", "</Items><Type>2002</Type>")),
            obstacle(BODY)
        );
    }
    assert_eq!(
        DecodeError::Structure(StructureError::Conflicting("Type")).to_string(),
        "<Type> is there twice, with different values"
    );
}

#[test]
fn tokenizer_yields_the_structure() {
    let mut t = Tokenizer::document(b"<?xml version='1.0'?><a><b x='1'>t</b><c/></a>");
    let mut tokens = Vec::new();
    while let Some(tok) = t.next_token().unwrap() {
        tokens.push(tok);
    }
    assert_eq!(
        tokens,
        vec![
            Token::Start(b"a"),
            Token::Start(b"b"),
            Token::Text(b"t"),
            Token::End(b"b"),
            Token::Empty(b"c"),
            Token::End(b"a"),
        ]
    );
}

/// The shortcuts skip whitespace a run of spaces at a time, with the line end or tab before
/// it; whatever the run's length (shorter or longer than the eight bytes skipped at once, or
/// cut by a tab or the input's end), whatever comes before it, and whatever byte ends it,
/// they read what the general path reads.
#[test]
fn runs_of_spaces_of_any_length_read_alike_by_both_paths() {
    for (spaces, before) in (0..=19).flat_map(|n| ["", "\n", "\r\n", "\t"].map(|b| (n, b))) {
        let run = " ".repeat(spaces);
        for after in ["", "\t", "\t ", "x", "\n", "\r\n"] {
            let gap = format!("{before}{run}{after}");
            for document in [
                BODY.replace("><", &format!(">{gap}<")),
                BODY.replacen("><", &format!(">{gap}<"), 1),
                format!("{BODY}{gap}"),
                format!("<?xml?>{gap}{BODY}"),
            ] {
                assert_read_alike(&document);
            }
        }
    }
}

/// A status answer's item lines as robots write them, one item a line in the table's order.
const STATUS_ITEMS: [&str; 21] = [
    "<MotionState>4</MotionState>",
    "<PosX>12.3456783</PosX>",
    "<PosY>-3.21098757</PosY>",
    "<PosZ>0.0412368812</PosZ>",
    "<Roll>-0.00023393621</Roll>",
    "<Pitch>0.0123587409</Pitch>",
    "<Yaw>1.57079637</Yaw>",
    "<Speed>0.498761237</Speed>",
    "<CurOdom>1.23456788</CurOdom>",
    "<SumOdom>1234.56787</SumOdom>",
    "<Res>0.0500000007</Res>",
    "<X0>-25.6000004</X0>",
    "<Y0>-18.3500004</Y0>",
    "<H>734</H>",
    "<Electricity>87</Electricity>",
    "<Location>0</Location>",
    "<GaitState>0</GaitState>",
    "<MotorState>0</MotorState>",
    "<ChargeState>0</ChargeState>",
    "<ControlMode>1</ControlMode>",
    "<OnDockState>0</OnDockState>",
];

/// The usual status answer's item lines, to be changed and put in a document.
fn status_items() -> Vec<String> {
    STATUS_ITEMS.iter().map(|l| l.to_string()).collect()
}

/// Asserts that the answer `document` decodes, or fails, alike by the shortcuts and by the
/// general path.
fn assert_read_alike(document: &str) {
    assert_eq!(
        format!("{:?}", Response::decode(document.as_bytes())),
        format!("{:?}", Response::decode_general(document.as_bytes())),
        "{document:?}"
    );
}

/// A status answer with `items`, indented as robots indent it.
fn status_answer(items: &[String]) -> String {
    let lines: String = items.iter().map(|l| format!("        {l}\n")).collect();
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n    <Type>1002</Type>\n    \
         <Command>1</Command>\n    <Time>2024-11-19 14:32:07</Time>\n    <Items>\n{lines}    \
         </Items>\n</PatrolDevice>\n"
    )
}

/// The shortcut for a block's item lines (each item the table lists next, written plainly,
/// its number read in the pass that finds the line's end) gives exactly what the general
/// path gives, for the lines it takes and for every line it must leave to the general path,
/// at the block's start, in its middle and at its end: a float's, an integer's and a code's
/// line with whitespace around the value, a sign, an exponent, C's words for a missing
/// reading, a decimal comma, too many digits, a value out of range, an entity or a comment
/// in the value; tags with a space, an attribute, another case, another name or none; an
/// item out of the table's order, repeated, unknown, or left empty.
#[test]
fn item_lines_read_alike_by_both_paths() {
    let values = "| 5|5 |+5|-5|5.0|5.5|.5|5.|-.5|-0.0|0.5e1|1,5|nan|-inf|0000007|1234567|12345678|\
        2147483648|255|256|0.0000000000000001|0.000000000000000012345|123456789012345678901234|\
        3.4028236e38|5&#x30;|<!--c-->5|1.5.5|5\t|\n5"
        .split('|')
        .collect::<Vec<_>>();
    let tags = [
        "<{n} >5</{n}>",
        "<{n} 5</{n} 5>",
        "<{n}55</{n}>",
        "<{n}>5</{n} >",
        "<{n} a=\"1\">5</{n}>",
        "<{n}>5</Other>",
        "<{n}/>",
        "<{n}></{n}>",
        "<PosX>9.5</PosX>",
        "<H>5</H>",
        "<Unknown>5</Unknown>",
        "<Pos>5</Pos>",
        "<AVeryLongUnknownItem>5</AVeryLongUnknownItem>",
        "<!-- a comment -->",
    ];
    let cases = values
        .iter()
        .map(|value| format!("<{{n}}>{value}</{{n}}>"))
        .chain(tags.iter().map(|tag| tag.to_string()));
    let mut checked = 0;
    for case in cases {
        // The first item (a code), a float in the middle, an integer, and the last item.
        for at in [0, 3, 13, STATUS_ITEMS.len() - 1] {
            let name = STATUS_ITEMS[at][1..].split('>').next().unwrap_or_default();
            let mut items = status_items();
            items[at] = case.replace("{n}", name);
            let document = status_answer(&items);
            assert_read_alike(&document);
            checked += 1;
        }
    }
    assert_eq!(checked, 4 * (values.len() + tags.len()));
    // A light request's colours are bytes: a value above 255 is refused by both paths.
    let light = [
        "<Red>1</Red>",
        "<Green>2</Green>",
        "<Blue>3</Blue>",
        "<PER>0</PER>",
        "<LUM>50</LUM>",
    ];
    for value in &values {
        for at in [0, 1, light.len() - 1] {
            let mut items = light.map(str::to_string);
            let name = &light[at][1..light[at].find('>').unwrap_or_default()];
            items[at] = format!("<{name}>{value}</{name}>");
            let document = format!(
                "<PatrolDevice>\n  <Type>1101</Type>\n  <Command>1</Command>\n  \
                 <Time>2024-11-19 14:32:07</Time>\n  <Items>\n    {}\n  </Items>\n</PatrolDevice>",
                items.join("\n    ")
            );
            assert_eq!(
                format!("{:?}", Request::decode(document.as_bytes())),
                format!("{:?}", Request::decode_general(document.as_bytes())),
                "{document}"
            );
        }
    }
    // The usual lines themselves, read by the shortcut, as the general path reads them.
    let usual = status_items();
    let document = status_answer(&usual);
    let decoded = Response::decode(document.as_bytes());
    assert_eq!(decoded, Response::decode_general(document.as_bytes()));
    let Ok(Response::Status(status)) = decoded.map(|d| d.message) else {
        panic!("the usual status answer reads: {document}");
    };
    assert_eq!(
        (
            status.pos_z,
            status.y0,
            status.h,
            status.control_mode.map(|m| m.raw())
        ),
        (0.041_236_88, -18.35, Some(734), Some(1))
    );
}

/// Items no table has (a real robot's status answer carries several), written plainly, are
/// passed over between the block's usual lines exactly as the general path passes over them;
/// any other extra line (a known item out of order or in other case, an entity, a nested
/// element, an attribute, an end tag that does not match) is left to the general path and
/// read, or refused, as it reads it. Many made-up names, so that some share the unknown-name
/// filter's bits with the table's names.
#[test]
fn extra_items_read_alike_by_both_paths() {
    let made_up: Vec<String> = (0..40)
        .map(|i| {
            let name = format!(
                "{}x{i}{}",
                ["Angle", "rtk", "Cur", "Z", "map"][i % 5],
                ["", "Yaw", "State", "E", "x"][i / 8]
            );
            format!("<{name}>{i}.5</{name}>")
        })
        .collect();
    let extras = [
        "<AngleYaw>1.57023621</AngleYaw>",
        "<CurRuntime>5421.33398</CurRuntime><SumRuntime>1536792.25</SumRuntime>",
        "<RTKState>0</RTKState>\n        <MapUpdateState>0</MapUpdateState>",
        "<Extra></Extra>",
        "<Extra> a text of words </Extra>",
        "<Extra>a&amp;b</Extra>",
        "<Extra>a&bogus;b</Extra>",
        "<Extra>5<!--c--></Extra>",
        "<Extra>5</Other>",
        "<Extra>5</Extra >",
        "<Extra >5</Extra>",
        "<Extra a=\"1\">5</Extra>",
        "<Extra><Sub>1</Sub></Extra>",
        "<Extra/>",
        "<Temp\u{e9}rature>21.5</Temp\u{e9}rature>",
        "<AVeryLongUnknownItemName>1</AVeryLongUnknownItemName>",
        "<posx>7.5</posx>",
        "<PosX>7.5</PosX>",
        "<ONDOCKSTATE>1</ONDOCKSTATE>",
        "<Electricity>55</Electricity>",
    ];
    let mut checked = 0;
    for extra in extras
        .iter()
        .copied()
        .chain(made_up.iter().map(String::as_str))
    {
        // Before the first item, after a float, after an integer and after the last item.
        for at in [0, 4, 14, STATUS_ITEMS.len()] {
            let mut items = status_items();
            items.insert(at, extra.to_string());
            let document = status_answer(&items);
            assert_read_alike(&document);
            checked += 1;
        }
    }
    assert_eq!(checked, 4 * (extras.len() + made_up.len()));
    // The real robot's layout: its extra items passed over, every usual item read.
    let mut items = status_items();
    for (at, extra) in [(4, extras[0]), (11, extras[1]), (18, extras[2])] {
        items.insert(at, extra.to_string());
    }
    let document = status_answer(&items);
    let Ok(Response::Status(status)) = Response::decode(document.as_bytes()).map(|d| d.message)
    else {
        panic!("the answer with extra items reads: {document}");
    };
    assert_eq!(
        (status.pos_z, status.roll, status.y0, status.h),
        (0.041_236_88, -0.000_233_936_21, -18.35, Some(734))
    );
}

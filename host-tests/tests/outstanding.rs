//! Which request an answer answers: by message ID in any order, a Type 0 answer whose ID
//! matches none to the oldest request.

use x30_panel::proto::outstanding::Outstanding;

/// Three requests outstanding, IDs 10, 11 and 12, remembered as "a", "b" and "c".
fn three() -> Outstanding<&'static str, 4> {
    let mut o = Outstanding::new();
    for (id, name) in [(10, "a"), (11, "b"), (12, "c")] {
        assert_eq!(o.push(id, name), None);
    }
    o
}

#[test]
fn answers_are_matched_by_id_in_any_order() {
    let mut o = three();
    assert_eq!(o.answer(12, false), Some((12, "c")));
    assert_eq!(o.answer(10, false), Some((10, "a")));
    assert_eq!(o.answer(11, false), Some((11, "b")));
    assert!(o.is_empty());
    // Each is answered once: a second answer with the same ID is unsolicited.
    assert_eq!(o.answer(11, false), None);
}

#[test]
fn a_type_0_answer_with_a_matching_id_answers_that_request() {
    let mut o = three();
    assert_eq!(o.answer(11, true), Some((11, "b")));
    assert_eq!(o.oldest(), Some(&(10, "a")));
}

#[test]
fn a_type_0_answer_whose_id_matches_none_answers_the_oldest() {
    let mut o = three();
    assert_eq!(o.answer(0, true), Some((10, "a")));
    assert_eq!(o.answer(999, true), Some((11, "b")));
    assert_eq!(o.len(), 1);
    assert!(o.contains(12));
    assert_eq!(o.answer(999, true), Some((12, "c")));
    assert_eq!(o.answer(999, true), None, "nothing left to answer");
}

#[test]
fn an_answer_of_another_type_whose_id_matches_none_answers_nothing() {
    let mut o = three();
    assert_eq!(o.answer(13, false), None);
    assert_eq!(o.len(), 3);
    assert_eq!(o.oldest(), Some(&(10, "a")));
}

#[test]
fn push_beyond_capacity_evicts_and_returns_the_oldest() {
    let mut o = three();
    assert_eq!(o.push(13, "d"), None, "four fit");
    assert_eq!(o.push(14, "e"), Some((10, "a")));
    assert_eq!(o.push(15, "f"), Some((11, "b")));
    assert_eq!(o.len(), 4);
    assert!(!o.contains(10) && !o.contains(11));
    // The evicted request's late answer is unsolicited.
    assert_eq!(o.answer(10, false), None);
    assert_eq!(o.oldest(), Some(&(12, "c")));
    assert_eq!(o.answer(15, false), Some((15, "f")));
}

#[test]
fn remove_gives_up_on_one_request() {
    let mut o = three();
    assert_eq!(o.remove(11), Some("b"));
    assert_eq!(o.remove(11), None);
    assert!(!o.contains(11));
    assert_eq!(o.len(), 2);
    // The order of the others is kept.
    assert_eq!(o.pop_oldest(), Some((10, "a")));
    assert_eq!(o.pop_oldest(), Some((12, "c")));
    assert_eq!(o.pop_oldest(), None);
}

#[test]
fn contains_len_and_clear() {
    let mut o: Outstanding<u8, 2> = Outstanding::default();
    assert!(o.is_empty());
    assert_eq!(o.len(), 0);
    assert_eq!(o.oldest(), None);
    o.push(7, 1);
    assert!(o.contains(7));
    assert!(!o.contains(8));
    assert_eq!((o.len(), o.is_empty()), (1, false));
    o.push(8, 2);
    o.clear();
    assert!(o.is_empty());
    assert!(!o.contains(7) && !o.contains(8));
    assert_eq!(o.answer(7, true), None, "nothing outstanding after a clear");
}

#[test]
fn get_looks_a_request_up_without_taking_it_out() {
    let mut o = three();
    assert_eq!(o.get(11), Some(&"b"));
    assert_eq!(o.get(99), None);
    assert_eq!(o.len(), 3, "nothing taken out");
    assert_eq!(o.answer(11, false), Some((11, "b")));
    assert_eq!(o.get(11), None, "answered");
}

#[test]
fn a_frame_that_does_not_echo_its_request_answers_nothing_but_type_0_still_does() {
    let mut o = three();
    assert_eq!(o.answer_if(11, false, |&r| r == "x"), None);
    assert!(o.contains(11), "still waiting for its answer");
    assert_eq!(o.answer_if(11, false, |&r| r == "b"), Some((11, "b")));
    assert_eq!(o.answer_if(12, true, |_| false), Some((12, "c")), "Type 0");
    assert_eq!(
        o.answer_if(99, true, |_| false),
        Some((10, "a")),
        "Type 0, oldest"
    );
}

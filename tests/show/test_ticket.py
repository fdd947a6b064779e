"""The ticket that binds a part to its conductor: HMAC-SHA256 (RFC 4231's test case 2 checks the
primitive, the rest what the show signs)."""

from choreo.show.ticket import new_ticket, signature, signed


def test_the_signature_is_hmac_sha256_of_the_fields():
    # RFC 4231, test case 2: key "Jefe", data "what do ya want for nothing?"
    assert signature("Jefe", "what do ya want for nothing?") == (
        "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"
    )


def test_a_signature_holds_only_for_its_ticket_and_its_fields():
    ticket = new_ticket()
    given = signature(ticket, "show-1", "stop", "Ctrl-C")
    assert signed(ticket, given, "show-1", "stop", "Ctrl-C")
    assert not signed(new_ticket(), given, "show-1", "stop", "Ctrl-C")
    assert not signed(ticket, given, "show-2", "stop", "Ctrl-C")
    assert not signed(ticket, given, "show-1", "beat", "Ctrl-C")
    # fields are kept apart: ("ab", "c") is not ("a", "bc")
    assert signature(ticket, "ab", "c") != signature(ticket, "a", "bc")


def test_tickets_are_128_random_bits():
    tickets = {new_ticket() for _ in range(100)}
    assert len(tickets) == 100
    assert all(len(t) == 32 and int(t, 16) >= 0 for t in tickets)

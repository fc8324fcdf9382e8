"""The plugin keeps femu-bench's optimizer contract (budget, seeding, silence, anytime)."""

from adapters.testing import check_optimizer


def test_example_de_keeps_the_contract():
    facts = check_optimizer("example-de")
    assert facts["capabilities"]["anytime"] and facts["min_budget"] == 90  # 15 x 6 parameters

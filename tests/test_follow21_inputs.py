"""Session 21, follow-ups of input checks: perturb_network takes the seeds every other
seed is (0 to 2**63 - 1); `mission --port` checks its URL's scheme before planning."""

from __future__ import annotations

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.link.port_urls import url_schemes


@pytest.mark.parametrize(
    ("seed", "shown"),
    [(-1, "-1"), (2**63, "9223372036854775808"), (1.5, "1.5"), ("3", "'3'"), (True, "True")],
    ids=["negative", "past-max", "float", "text", "bool"],
)
def test_perturb_network_refuses_a_seed_no_campaign_takes(seed: object, shown: str) -> None:
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import perturb_network

    drawing = load_network("lab").spec
    # -1 gave variant 1 (Python's random seeds by the number's size); 1.5 and '3' others
    with pytest.raises(InputError) as caught:
        perturb_network(drawing, seed)  # type: ignore[arg-type]
    assert str(caught.value) == f"seed: give a whole number from 0 to 2**63 - 1, not {shown}"


def test_perturb_network_takes_every_seed_a_campaign_does() -> None:
    np = pytest.importorskip("numpy")
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import perturb_network

    drawing = load_network("lab").spec
    assert perturb_network(drawing, np.int64(3)) == perturb_network(drawing, 3)
    assert perturb_network(drawing, 0) != perturb_network(drawing, 1)
    perturb_network(drawing, 2**63 - 1)


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("bogus://x", "no URL scheme 'bogus' here: a port is a device (/dev/ttyACM0, COM3) or"),
        ("spy://", "nothing after spy://; give spy://DEVICE"),
        ("socket://localhost", "no port; give socket://HOST:PORT"),
    ],
    ids=["scheme", "nothing", "no-port"],
)
def test_a_mission_s_port_url_is_refused_before_the_plan_is_printed(
    url: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # the whole plan was printed on stdout, then the port was refused, exit 2
    assert main(["mission", "lab", "--port", url]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith(f"pirate-bt: --port: cannot open {url}: {said}")
    assert len(err.splitlines()) == 1
    if url == "bogus://x":
        assert err.rstrip("\n").endswith(", ".join(f"{s}://" for s in url_schemes()))


def test_the_api_refuses_a_port_url_before_it_plans() -> None:
    import pirate_bt
    from pirate_bt.link.transport import PortURLError

    # a route that does not fit its map: planning it would be the refusal said first
    with pytest.raises(PortURLError, match=r"^cannot open bogus://x: no URL scheme 'bogus'"):
        pirate_bt.run_mission("lab", network="straight", port="bogus://x")


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"bounds": "x"}, "bounds: give an AsBuiltBounds (None: the defaults), not a str"),
        ({"name": 5}, "name: give the variant's name as text, not an int"),
        ({"name": " "}, "name: empty; give the variant's name, or None for the default"),
    ],
    ids=["bounds", "name-int", "name-empty"],
)
def test_perturb_network_refuses_bounds_and_names_of_the_wrong_kind(
    kwargs: dict[str, object], said: str
) -> None:
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import perturb_network

    # bounds='x' raised "'str' object has no attribute 'describe'"; name=5 named it 5
    with pytest.raises(InputError) as caught:
        perturb_network(load_network("lab").spec, 3, **kwargs)  # type: ignore[arg-type]
    assert str(caught.value) == said


@pytest.mark.parametrize("limit", ["0 s", "-5 s", "1e300 s"])
def test_a_mission_s_time_limit_is_refused_before_the_plan_is_printed(
    limit: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # the whole plan was printed, then 'max_time: ...' (the API's name) refused it; -5 s
    # was refused as a tick rate too high for it
    assert main(["mission", "lab", "--max-time", limit]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (
        f"pirate-bt: --max-time: {limit!r} is out of range; give a time above 0 s and at"
        " most 1e+09 s\n"
    )


def test_a_mission_s_firmware_chain_with_a_port_is_refused_before_the_plan_is_printed(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the whole plan was printed first
    assert main(["mission", "lab", "--firmware-chain", "--port", "/dev/pirate-bt-no-tty"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (
        "pirate-bt: --firmware-chain runs the simulator through the firmwares; with --port"
        " the real bridge runs its own\n"
    )

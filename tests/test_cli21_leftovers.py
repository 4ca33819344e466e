"""Session 21, the command line's leftovers: inputs that were taken without a word (a
teleop script's unknown key, ...) and messages that named the wrong thing."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def test_an_unknown_teleop_key_is_refused_before_anything_is_sent(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import pirate_bt.api.connection as connection

    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("the robot was reached")

    monkeypatch.setattr(connection, "connect", never)
    # 'W' (a capital, caps lock on) was a tick with nothing done, exit 0
    assert main(["teleop", "--keys", "ffW."]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.splitlines()) == 1
    assert err.startswith("pirate-bt: --keys: 'W' (character 3) is no key; the keys are ")
    for known in ("w", "s", "space", "q", "?"):
        assert f" {known}" in err
    assert "'.' waits a tick" in err


def test_a_dot_in_teleop_keys_waits_a_tick(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["teleop", "--keys", "..?"]) == 0, capsys.readouterr().err
    out, err = capsys.readouterr()
    assert err == ""
    assert out.splitlines()[-1].startswith("  mode manual;")


def test_a_sim_seed_without_noise_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # it seeds the sensor noise alone: without --noise it was taken, and the simulator
    # served was the same whatever the seed, exit 0
    assert main(["sim", "--tcp", "0", "--duration", "0.1", "--seed", "3"]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing served
    assert err == (
        "pirate-bt: --seed is for --noise (it seeds the sensor noise; without noise nothing"
        " in the simulator is random): add --noise or leave it out\n"
    )
    assert main(["sim", "--tcp", "0", "--duration", "0.1", "--seed", "3", "--noise"]) == 0
    assert capsys.readouterr().out.startswith("socket://127.0.0.1:")


def test_a_teleop_seed_is_refused_it_seeds_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    # taken, exit 0, and the session was the same whatever the seed
    assert main(["teleop", "--keys", "q", "--seed", "3"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (
        "pirate-bt: --seed: the teleop's simulator has no sensor noise and no faults, nothing"
        " in it is random; leave --seed out\n"
    )


ROW = (
    '{"id": "000000-0a1b2c3d", "index": 0, "run": "a", "seed": 0, "outcome": "success",'
    ' "reason": "done", "sim_time_s": 1.0, "wall_time_s": 0.5}\n'
)


@pytest.mark.parametrize(
    "option",
    [["--output", "elsewhere"], ["--workers", "2"], ["--resume"], ["--case-timeout", "9 s"]],
    ids=["output", "workers", "resume", "case-timeout"],
)
def test_campaign_report_refuses_the_options_of_a_run(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    option: list[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    results = tmp_path / "results.jsonl"
    results.write_text(ROW)
    # was taken and dropped, exit 0: '--output elsewhere' wrote the report beside the
    # results, not where it was asked for
    assert main(["campaign", "report", str(results), *option]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (
        f"pirate-bt: campaign report: {option[0]} is for running a campaign; the report runs"
        " no case and is written beside its results file\n"
    )
    assert list(tmp_path.iterdir()) == [results]  # no report written


@pytest.mark.parametrize("seed", ["-1", str(2**63)])
def test_network_perturb_refuses_a_seed_no_campaign_takes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: str
) -> None:
    out = tmp_path / "v.yaml"
    # '--seed -1' wrote variant 1 (random.Random(-1) is Random(1)) named 'lab-asbuilt--1'
    assert main(["network", "perturb", "lab", "--seed", seed, "-o", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: --seed: give a whole number from 0 to 2**63 - 1, not {seed}\n"
    )
    assert not out.exists()

"""Protocol files: the shipped ones load, unknown keys and bad values are one-line errors."""

from pathlib import Path

import pytest

from limbstiff.errors import ProtocolError
from limbstiff.protocol import Protocol, load_protocol

PROTOCOLS = Path(__file__).resolve().parents[1] / "protocols"


@pytest.mark.parametrize("path", sorted(PROTOCOLS.glob("*.toml")), ids=lambda p: p.stem)
def test_shipped_protocols_load(path):
    p = load_protocol(path)
    assert p.name == path.stem


def test_reklab_flips_torque_and_maps_position():
    p = load_protocol(PROTOCOLS / "reklab-ankle.toml")
    assert p.columns["torque"].scale == -1.0
    assert p.columns["angle"].header == "position_rad"
    assert p.variant == "external" and p.observer_gain is None        # "auto"


def test_vsa_bench_is_the_papers_setup():
    # Sec. V: Ts = 0.015 s, prefilter time constant 0.02 s, D(s) = s/(1 + 1e-4 s), α = 3.
    p = load_protocol(PROTOCOLS / "vsa-bench.toml")
    assert (p.sample_period, p.prefilter_time_constant, p.dirty_derivative_time_constant,
            p.observer_gain, p.derivatives) == (0.015, 0.02, 1e-4, 3.0, "paper")


def _write(tmp_path, text):
    f = tmp_path / "p.toml"
    f.write_text(text)
    return f


@pytest.mark.parametrize("text, phrase", [
    ("colour = 'red'\n", "unknown key(s) colour"),
    ("[observer]\ngian = 3\n", "unknown key(s) in [observer]: gian"),
    ("[columns.pressure]\nheader = 'p'\n", "unknown quantity 'pressure'"),
    ("[columns.torque]\nheader = 'T'\nsign = -1\n", "unknown key(s) in [columns.torque]: sign"),
    ("[observer]\nvariant = 'both'\n", "'variant' must be one of"),
    ("[observer]\ngain = -3\n", "'observer_gain' must be a positive number"),
    ("[mechanics]\ninertia = 0\n", "'inertia' must be a positive number"),
    ("[priors.inertia]\ndistribution = 'lognormal'\nmedian = 0.01\n", "'sigma' must be a positive number"),
    ("[priors.mass]\nscale = 1\n", "unknown prior 'mass'"),
    ("[report]\nci_level = 1.5\n", "'ci_level' must be a number between 0 and 1"),
    ("name = 3\n", "'name' has the wrong type"),
    ("[observer\n", "not valid TOML"),
])
def test_bad_protocols_are_one_line_errors(tmp_path, text, phrase):
    f = _write(tmp_path, text)
    with pytest.raises(ProtocolError) as info:
        load_protocol(f)
    message = str(info.value)
    assert phrase in message and str(f) in message and "\n" not in message


def test_missing_protocol_file(tmp_path):
    with pytest.raises(ProtocolError, match="protocol file not found"):
        load_protocol(tmp_path / "nope.toml")


def test_overrides_take_precedence_and_none_keeps_the_file():
    p = Protocol(observer_gain=3.0, inertia=0.05)
    q = p.override(observer_gain=10.0, inertia=None)
    assert (q.observer_gain, q.inertia) == (10.0, 0.05)
    assert p.observer_gain == 3.0                       # frozen: the original is unchanged
    with pytest.raises(ProtocolError):
        p.override(damping=-1.0)


def test_unknown_unit_in_protocol_is_caught_at_load(tmp_path):
    f = _write(tmp_path, "[columns.angle]\nheader = 'pos'\nunit = 'grad'\n")
    with pytest.raises(ProtocolError, match="unknown unit 'grad' for angle"):
        load_protocol(f)


def test_every_public_name_of_the_package_is_imported_from_limbstiff_protocol():
    # the package's modules are split by idea; limbstiff.protocol stays the one import path
    import ast

    import limbstiff.protocol as protocol
    from limbstiff.protocol import reading, settings

    for module in (settings, reading):
        tree = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
        defined = [n.name for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))]
        defined += [t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)]
        public = [n for n in defined if not n.startswith("_")]
        assert public, module.__name__
        for name in public:
            assert name in protocol.__all__ and getattr(protocol, name) is getattr(module, name), name


def test_unknown_keys_are_named_in_every_table():
    from limbstiff.protocol import protocol_from_dict

    for raw, said in (({"format": {"delim": ","}}, r"\[format\]: delim"),
                      ({"columns": {"angle": {"head": "x"}}}, r"\[columns.angle\]: head"),
                      ({"priors": {"inertia": {"mean": 1.0}}}, r"\[priors.inertia\]: mean"),
                      ({"cycles": {"period": 1.0}}, r"\[cycles\]: period \(period_s, start_s, marker\)")):
        with pytest.raises(ProtocolError, match=said):
            protocol_from_dict(raw)

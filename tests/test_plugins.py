"""Plugin loading through entry points: fake distributions, a broken one, and a
name registered twice."""

from __future__ import annotations

import sys
import textwrap

import pytest

from wsgrasp.errors import PluginError
from wsgrasp.plugins import PluginInfo, Registry, hookimpl


def _fake_distribution(root, dist: str, module: str, source: str, version="1.2.3"):
    """Write an installed-looking distribution (module + dist-info) under root."""
    (root / f"{module}.py").write_text(textwrap.dedent(source))
    # dist-info folders spell the name with underscores (importlib.metadata
    # splits the folder name at the first hyphen)
    info = root / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n"
    )
    (info / "entry_points.txt").write_text(f"[wsgrasp]\n{dist} = {module}\n")


@pytest.fixture
def fake_site(tmp_path, monkeypatch):
    """A directory on sys.path for fake plugin distributions, removed afterwards."""
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    for name in [m for m in sys.modules if m.startswith("fakeplug_")]:
        del sys.modules[name]


GOOD = """
from wsgrasp import hookimpl

class Sharp:
    from pydantic import BaseModel as _B
    class Options(_B):
        pass
    def score(self, batch, options):
        return batch.contacts.sum(axis=1) * 0.0

@hookimpl
def wsgrasp_register_scorers(register):
    register("sharp", Sharp)
"""


def test_fake_distribution_registers_through_entry_points(fake_site):
    _fake_distribution(fake_site, "fake-scorers", "fakeplug_good", GOOD)
    reg = Registry.from_entry_points()
    entry = reg.get("scorers", "sharp")
    assert entry.plugin.distribution == "fake-scorers"
    assert entry.plugin.version == "1.2.3"
    # the built-ins come through the same path
    assert "centroid_distance" in reg.names("scorers")
    assert reg.get("scorers", "centroid_distance").plugin.distribution == "wsgrasp"
    summary = {p["distribution"]: p for p in reg.plugin_summary()}
    assert summary["fake-scorers"]["provides"] == {"scorers": ["sharp"]}


def test_broken_plugin_is_reported_and_others_still_load(fake_site):
    _fake_distribution(
        fake_site, "fake-broken", "fakeplug_broken", "raise ImportError('no numpy 9')"
    )
    _fake_distribution(fake_site, "fake-scorers", "fakeplug_good", GOOD)
    reg = Registry.from_entry_points()
    assert "sharp" in reg.names("scorers")
    failed = {f.plugin.distribution: f for f in reg.failed}
    assert "fake-broken" in failed
    assert "no numpy 9" in failed["fake-broken"].error


def test_hook_that_raises_is_reported(fake_site):
    _fake_distribution(
        fake_site,
        "fake-raiser",
        "fakeplug_raiser",
        """
        from wsgrasp import hookimpl

        @hookimpl
        def wsgrasp_register_segmenters(register):
            raise RuntimeError("boom")
        """,
    )
    reg = Registry.from_entry_points()
    (failure,) = [f for f in reg.failed if f.plugin.distribution == "fake-raiser"]
    assert "wsgrasp_register_segmenters" in failure.error and "boom" in failure.error
    assert "ransac_dbscan" in reg.names("segmenters")


def test_duplicate_name_names_both_distributions(fake_site):
    _fake_distribution(fake_site, "fake-scorers", "fakeplug_good", GOOD)
    _fake_distribution(fake_site, "fake-copycat", "fakeplug_copy", GOOD)
    reg = Registry.from_entry_points()
    with pytest.raises(PluginError) as info:
        reg.get("scorers", "sharp")
    assert "fake-scorers" in str(info.value) and "fake-copycat" in str(info.value)
    # other names are unaffected
    assert reg.get("scorers", "antipodal")


def test_unknown_name_suggests_close_ones():
    reg = Registry.from_entry_points()
    with pytest.raises(PluginError, match="did you mean 'centroid_distance'"):
        reg.get("scorers", "centroid_distanse")


def test_register_and_unregister_a_plugin_object():
    class Plugin:
        @hookimpl
        def wsgrasp_register_scorers(self, register):
            register("tiny", object)

    reg = Registry()
    info = PluginInfo("tiny", "tests", "0")
    reg.add_plugin(Plugin(), info)
    assert reg.names("scorers") == ["tiny"]
    reg.remove_plugin(info)
    assert reg.names("scorers") == []


def test_hook_with_wrong_signature_is_rejected():
    class Bad:
        @hookimpl
        def wsgrasp_register_scorers(self, register, extra):
            pass

    reg = Registry()
    reg.add_plugin(Bad(), PluginInfo("bad", "tests", "0"))
    assert reg.failed and "extra" in reg.failed[0].error

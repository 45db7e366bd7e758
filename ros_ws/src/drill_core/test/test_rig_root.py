"""The rig's checkout: RIG_ROOT when set, else the checkout the code runs from."""
from pathlib import Path

from drill_core import rig_root


def test_rig_root_is_the_variable_when_set(monkeypatch, tmp_path):
    monkeypatch.setenv("RIG_ROOT", str(tmp_path))
    assert rig_root.rig_root() == tmp_path
    assert rig_root.config_dir() == tmp_path / "config"


def test_without_the_variable_it_is_the_checkout_holding_this_code(monkeypatch, tmp_path):
    monkeypatch.delenv("RIG_ROOT", raising=False)
    monkeypatch.chdir(tmp_path)                       # not the working directory
    root = rig_root.rig_root()
    assert (root / "config" / "well.yaml").is_file()
    assert Path(rig_root.__file__).resolve().is_relative_to(root)

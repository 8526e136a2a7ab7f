"""yasps.config.override: settings for a with-block, checked first and
restored after it, also when it raises; and the list of settings it takes
is the module's."""

import types

import pytest

import yasps


def test_override_sets_settings_for_a_block_and_restores_them():
    before = (yasps.config.precision, yasps.config.num_threads)
    with yasps.config.override(precision="f32", num_threads=1):
        assert (yasps.config.precision, yasps.config.num_threads) == ("f32", 1)
        with yasps.config.override(num_threads=2):
            assert yasps.config.num_threads == 2
        assert yasps.config.num_threads == 1
    assert (yasps.config.precision, yasps.config.num_threads) == before
    with pytest.raises(RuntimeError, match="inside"):
        with yasps.config.override(precision="f32"):
            raise RuntimeError("inside")
    assert yasps.config.precision == before[0]


def test_override_refuses_unknown_names_and_bad_values_changing_nothing():
    before = yasps.config.precision
    with pytest.raises(yasps.ArgumentError, match="no setting 'precison'"):
        with yasps.config.override(precison="f32"):
            pass
    with pytest.raises(yasps.ArgumentError, match="config.opt_level must be"):
        with yasps.config.override(precision="f32", opt_level=7):
            pass
    assert yasps.config.precision == before


def test_settings_lists_every_setting_of_the_module():
    module = vars(yasps.config)
    settings = {name for name, value in module.items()
                if name.islower() and not name.startswith("_")
                and name != "annotations" and not callable(value)
                and not isinstance(value, (tuple, types.ModuleType))}
    assert settings == set(yasps.config.SETTINGS)


def test_snapshot_holds_every_setting_and_follows_changes():
    """Caches are keyed by config.snapshot(): every setting is in it, and
    a changed setting changes it."""
    before = yasps.config.snapshot()
    assert [name for name, _ in before] == list(yasps.config.SETTINGS)
    with yasps.config.override(opt_level=1 if yasps.config.opt_level != 1
                               else 2):
        assert yasps.config.snapshot() != before
    assert yasps.config.snapshot() == before

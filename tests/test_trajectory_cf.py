"""trajectory.h5 against the CF conventions: the CF checker (cfchecker) finds no
error and no warning; event_kind is a CF flag variable that reads back as names;
files with the earlier string event_kind still read."""

import dataclasses
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

import granular_chain as gc
from granular_chain.codes import EVENT_KINDS
from granular_chain.result import Event
from granular_chain.writers.summary import write_summary
from granular_chain.conventions import event_kind_names
from granular_chain.writers.trajectory import write_trajectory

ROOT = Path(__file__).resolve().parents[1]
EVENTS = [Event(0.25, "contact_close", 0, 25), Event(0.5, "slip", 1, 50),
          Event(1.0, "contact_open", 0, 100), Event(1.75, "stop", 1)]

# The checker reads three tables from cfconventions.org; without a network it is
# given empty local ones (the file uses no standard_name, area type or region).
_TABLES = {
    "std": "<standard_name_table><version_number>0</version_number>"
           "<last_modified>local</last_modified></standard_name_table>",
    "area": "<area_type_table><version_number>0</version_number><date>local</date>"
            "</area_type_table>",
    "region": "<standardized_region_list><version_number>0</version_number><date>local</date>"
              "</standardized_region_list>",
}


@pytest.fixture(scope="module", params=["scaled", "physical"])
def written(request, tmp_path_factory):
    """A run folder of the two-granule scene, with every kind of event put in."""
    scene = gc.load_scene(ROOT / "scenarios" / "two_granules.yaml",
                          ["output.every=500", f"units={request.param}"])
    result = dataclasses.replace(gc.simulate(scene, progress=False), events=list(EVENTS))
    folder = tmp_path_factory.mktemp(request.param)
    write_trajectory(result, folder, scene)
    write_summary(result, folder, scene)
    return folder, result


def test_event_kind_is_a_flag_variable_that_reads_back(written):
    folder, result = written
    with h5py.File(folder / "trajectory.h5") as h5:
        kind = h5["event_kind"]
        assert kind.dtype == np.int8 and "units" not in kind.attrs
        assert list(kind.attrs["flag_values"]) == [0, 1, 2, 3]
        assert kind.attrs["flag_meanings"] == "contact_close contact_open stop slip"
        assert list(kind[...]) == [EVENT_KINDS.index(e.kind) for e in EVENTS] == [0, 3, 1, 2]
        assert event_kind_names(kind) == [e.kind for e in EVENTS]
    assert gc.read_run(folder).events == EVENTS


def test_a_file_with_string_event_kinds_still_reads(written, tmp_path):
    """Files written before the flag encoding hold event_kind as variable-length strings."""
    folder, _ = written
    for name in ("trajectory.h5", "summary.json"):
        shutil.copy(folder / name, tmp_path / name)
    with h5py.File(tmp_path / "trajectory.h5", "r+") as h5:
        del h5["event_kind"]
        old = h5.create_dataset("event_kind", data=np.array([e.kind for e in EVENTS], dtype=object),
                                dtype=h5py.string_dtype())
        old.dims[0].attach_scale(h5["event"])
    assert gc.read_run(tmp_path).events == EVENTS


def test_time_is_elapsed_time_not_a_calendar_axis(written):
    folder, _ = written
    with h5py.File(folder / "trajectory.h5") as h5:
        attrs = dict(h5["time"].attrs)
        assert h5.attrs["Conventions"] == "CF-1.8"
    assert "axis" not in attrs and "since" not in attrs["units"]
    assert attrs["units"] in ("1", "s") and "since the start of the run" in attrs["long_name"]


def test_the_cf_checker_finds_no_error_and_no_warning(written, tmp_path):
    cfchecks = pytest.importorskip("cfchecker.cfchecks",
                                   reason="cfchecker (pip install cfchecker; needs udunits2)")
    folder, _ = written
    tables = {}
    for name, text in _TABLES.items():
        tables[name] = tmp_path / f"{name}.xml"
        tables[name].write_text('<?xml version="1.0"?>\n' + text)
    nc = tmp_path / "trajectory.nc"  # the checker refuses a name without .nc (CF 2.1)
    shutil.copy(folder / "trajectory.h5", nc)
    checker = cfchecks.CFChecker(cfStandardNamesXML=str(tables["std"]),
                                 cfAreaTypesXML=str(tables["area"]),
                                 cfRegionNamesXML=str(tables["region"]), silent=True)
    checker.checker(str(nc))
    counts = checker.get_counts()
    assert counts["FATAL"] == counts["ERROR"] == counts["WARN"] == 0, checker.all_messages
    assert checker.results["variables"]["event_kind"]  # (the variables were checked)

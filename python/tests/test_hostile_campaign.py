"""The hostile campaign (hostile_campaign.py) in the suite: its --quick run, about 1,800 cases in some thirty
seconds, must give no SILENT WRONG, BAD ERROR, CRASH or HANG. The program's cases run where MLSDEFORM_CLI names
the program (ctest sets it), and are skipped otherwise.
"""
import json
import os
import subprocess
import sys
import tempfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))

FAILURES = ("SILENT WRONG", "BAD ERROR", "CRASH", "HANG")


@pytest.fixture(scope="module")
def outcomes():
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "outcomes.json")
        r = subprocess.run(
            [sys.executable, os.path.join(HERE, "hostile_campaign.py"), "--quick", "--json", path],
            capture_output=True,
            text=True,
            timeout=600,
        )
        print(r.stdout[-4000:], r.stderr[-2000:])
        assert os.path.exists(path), f"the campaign did not finish: exit {r.returncode}\n{r.stderr[-2000:]}"
        with open(path) as fh:
            return json.load(fh)


def test_campaign_size(outcomes):
    assert len(outcomes) >= 500


def test_no_failure(outcomes):
    failed = [
        f"#{c['id']} [{c['tag']}] {c['name']}: {c['outcome']}: {c['detail']}"
        for c in outcomes
        if c["outcome"] in FAILURES
    ]
    assert not failed, "\n".join(failed)

"""Regenerate the Python client (``shapesearch_client``) from the OpenAPI snapshot.

    python clients/python/regenerate.py            # rewrite clients/python/shapesearch_client
    python clients/python/regenerate.py --output DIR   # write the package into DIR instead

The snapshot (tests/snapshots/openapi.json) is the contract the tests hold the service to;
the client is generated from it by openapi-python-client (pinned in the test extra, with
the settings of openapi-python-client.yaml), with any generator warning an error. The same
snapshot and generator give the same files, which tests/test_client.py checks.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SNAPSHOT = HERE.parents[1] / "tests" / "snapshots" / "openapi.json"
CONFIG = HERE / "openapi-python-client.yaml"
PACKAGE = "shapesearch_client"


def generate(output: Path) -> None:
    """Write the generated package into ``output`` (replaced if it exists).

    Parameters
    ----------
    output : Path
        The package directory to write, e.g. ``clients/python/shapesearch_client``.
    """
    with tempfile.TemporaryDirectory() as scratch:
        package = Path(scratch) / PACKAGE
        run = subprocess.run(
            [
                sys.executable, "-m", "openapi_python_client", "generate",
                "--path", str(SNAPSHOT), "--config", str(CONFIG), "--meta", "none",
                "--output-path", str(package), "--fail-on-warning",
            ],
            capture_output=True, text=True,
        )
        if run.returncode != 0:
            raise RuntimeError(f"openapi-python-client failed:\n{run.stdout}{run.stderr}")
        (package / "py.typed").write_text("")  # PEP 561: the client ships its types
        if output.exists():
            shutil.rmtree(output)
        shutil.copytree(package, output)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=HERE / PACKAGE,
                        help="package directory to write (default: %(default)s)")
    generate(parser.parse_args().output)
    return 0


if __name__ == "__main__":
    sys.exit(main())

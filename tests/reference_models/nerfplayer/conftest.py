import pytest

from tests.reference_models.common.tiny import render_tiny


@pytest.fixture(scope="session")
def tiny_data(tmp_path_factory):
    return render_tiny(tmp_path_factory.mktemp("models") / "tiny")

"""docker/: the compose services run the project's own make targets (no daemon needed)."""

import re

import yaml

from .helpers import ROOT


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text()
    return set(re.findall(r"^([a-z][a-z_-]*):", text, flags=re.M))


def test_compose_services_use_make_targets():
    compose = yaml.safe_load((ROOT / "docker/compose.yaml").read_text())
    targets = _make_targets()
    assert {"demo", "test", "serve", "tail", "tables", "install"} <= targets
    services = compose["services"]
    assert set(services) == {"radar", "subscriber"}
    for svc in services.values():
        assert svc["build"] == {"context": "..", "dockerfile": "docker/Dockerfile"}
        cmd = svc["command"]
        assert cmd[0] == "make" and cmd[1] in targets
    radar = services["radar"]["command"]
    # inside a container the service must bind all interfaces, and say so explicitly
    assert "ENDPOINT=tcp://0.0.0.0:5556" in radar
    assert any("--allow-insecure-remote" in a for a in radar)
    # published on the host's loopback only
    assert services["radar"]["ports"] == ["127.0.0.1:5556:5556"]
    assert "ENDPOINT=tcp://radar:5556" in services["subscriber"]["command"]


def test_dockerfile_installs_and_serves_through_make():
    text = (ROOT / "docker/Dockerfile").read_text()
    assert re.search(r"^RUN make install && make tables", text, flags=re.M)
    assert 'CMD ["make", "serve"]' in text

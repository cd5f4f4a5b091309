"""The port contract of a LeafSystem, checked the way Drake's own tests do
(bindings/pydrake/systems/test/custom_test.py): port names and sizes in
order, and that the system's docstring (its `.. pydrake_system::` block)
shows exactly those ports."""

import re

from pydrake.systems.framework import DiagramBuilder, PortDataType


def docstring_ports(system_type: type) -> tuple[list[str], list[str]]:
    """The input and output port names of a `.. pydrake_system::` block."""
    doc = system_type.__doc__ or ""
    assert ".. pydrake_system::" in doc, f"{system_type.__name__} has no pydrake_system block"
    block = doc.split(".. pydrake_system::", 1)[1]
    ports: dict[str, list[str]] = {"input_ports": [], "output_ports": []}
    section = None
    for line in block.splitlines():
        text = line.strip()
        if text in ("input_ports:", "output_ports:"):
            section = text[:-1]
        elif text.startswith("- ") and section:  # "(optional ...)" after a name: a port some systems have
            ports[section].append(text[2:].split()[0] + ("?" if "(optional" in text else ""))
        elif text and not text.startswith("name:") and section:
            break
    return ports["input_ports"], ports["output_ports"]


def _matches(documented: list[str], names: list[str]) -> bool:
    """`latent_<part>` in a docstring stands for one or more ports named so, `name?` for an optional one."""

    def one(d: str) -> str:
        if "<" in d:
            return f"(?:{re.escape(d.split('<')[0])}\\w+,)+"
        return f"(?:{re.escape(d[:-1])},)?" if d.endswith("?") else f"{re.escape(d)},"

    pattern = "".join(one(d) for d in documented)
    return re.fullmatch(pattern, "".join(f"{n}," for n in names)) is not None


def _port_sizes(ports) -> dict[str, int | None]:
    return {p.get_name(): (p.size() if p.get_data_type() == PortDataType.kVectorValued else None) for p in ports}


def assert_port_contract(system, inputs: dict[str, int | None], outputs: dict[str, int | None]) -> None:
    """`inputs`/`outputs`: name -> vector size, or None for an abstract port, in port order."""
    got_in = _port_sizes(system.get_input_port(i) for i in range(system.num_input_ports()))
    got_out = _port_sizes(system.get_output_port(i) for i in range(system.num_output_ports()))
    assert list(got_in.items()) == list(inputs.items())
    assert list(got_out.items()) == list(outputs.items())
    doc_in, doc_out = docstring_ports(type(system))
    assert _matches(doc_in, list(got_in)), (doc_in, list(got_in))
    assert _matches(doc_out, list(got_out)), (doc_out, list(got_out))


def assert_inputs_wired(builder: DiagramBuilder, system) -> None:
    """Every input port of `system` is connected (what its Add helper promises)."""
    for i in range(system.num_input_ports()):
        port = system.get_input_port(i)
        assert builder.IsConnectedOrExported(port), port.get_name()

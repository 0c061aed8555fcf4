"""No import cycles inside tca_ros, counting imports inside functions too.

A lazy import hides a cycle from the interpreter but not from the reader: the two modules
still depend on each other. The graph is read from the source with ``ast``.
"""
import ast
import pathlib

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / 'tca_ros'


def _module_name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imports(path, modules):
    """Return the tca_ros modules that ``path`` imports (module or function level)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f'{node.module}.{a.name}' for a in node.names]
        else:
            continue
        found.update(n for n in names if n in modules)
    return found


def import_graph():
    """Return {module: set of tca_ros modules it imports} over the package."""
    paths = {_module_name(p): p for p in PACKAGE.rglob('*.py')}
    return {name: _imports(path, paths) - {name} for name, path in paths.items()}


def cycles(graph):
    """Return the strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_checker_finds_a_cycle():
    assert cycles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [['a', 'b', 'c']]
    assert cycles({'a': {'b'}, 'b': set()}) == []


def test_tca_ros_has_no_import_cycle():
    # a package's __init__ importing its own modules is not a cycle of the code
    graph = {m: {d for d in deps if not (m.startswith(d + '.') and d != 'tca_ros')}
             for m, deps in import_graph().items()}
    assert cycles(graph) == []

"""One module per node: it reads its parameters into a settings dataclass, builds its core
(in the library floor), converts messages and spins. Each is a console script."""

from os import PathLike
from typing import Any, Iterable, Optional, Union

def montecarlo(scenario: Union[str, PathLike], seeds: Union[None, str, Iterable[int]], client: Any,
               chunk_size: Optional[int] = None, threads_per_task: Optional[int] = 1) -> dict: ...

import os, pytest
_last = [None]
@pytest.fixture(autouse=True)
def _fd(request):
    n0 = len(os.listdir('/proc/self/fd'))
    yield
    n1 = len(os.listdir('/proc/self/fd'))
    if n1 > n0:
        with open("/tmp/fdleak.txt", "a") as f:
            f.write(f"{n1-n0:+d} -> {n1} {request.node.nodeid}\n")

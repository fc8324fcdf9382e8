import signal, pytest
@pytest.fixture(autouse=True)
def _sig(request):
    before = signal.getsignal(signal.SIGINT); mb = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    yield
    after = signal.getsignal(signal.SIGINT); ma = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    if after is not before or ma != mb:
        with open("/tmp/sigchanged.txt", "a") as f:
            f.write(f"{request.node.nodeid}: {before} -> {after}; mask {mb} -> {ma}\n")

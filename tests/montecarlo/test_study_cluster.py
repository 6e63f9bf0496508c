"""carav study's embedded Dask cluster speaks TLS with a key of its own: a process without that key can neither
connect to its scheduler nor submit work."""
import pytest
from dask.distributed import Client
from distributed.security import Security

from carav_stream.montecarlo.study import local_cluster

pytestmark = pytest.mark.integration


def test_the_embedded_cluster_refuses_a_client_without_its_key():
    cluster, security = local_cluster(1)
    try:
        assert cluster.scheduler_address.startswith("tls://127.0.0.1:")
        with Client(cluster, security=security, timeout="60s") as ok:
            assert ok.submit(sum, [1, 2]).result() == 3
        with pytest.raises((OSError, TimeoutError)):                               # TLS with a key of its own
            Client(cluster.scheduler_address, security=Security.temporary(), timeout="5s")
        plain = cluster.scheduler_address.replace("tls://", "tcp://")
        with pytest.raises((OSError, TimeoutError)):
            Client(plain, timeout="3s")                                            # plain TCP to a TLS port
    finally:
        cluster.close()

"""The Dask dashboard a local scene cluster reports is served, on the loopback interface."""

from __future__ import annotations

import urllib.parse
import urllib.request

from radcons.scene.cluster import SceneCluster


def test_the_dashboard_link_of_a_local_cluster_answers_on_loopback():
    with SceneCluster(workers=1, processes=False) as cluster:
        link = cluster.dashboard
        assert link is not None
        assert urllib.parse.urlsplit(link).hostname == "127.0.0.1"
        with urllib.request.urlopen(link, timeout=30) as response:
            page = response.read().decode("utf-8", "replace")
        assert response.status == 200 and "Dask" in page

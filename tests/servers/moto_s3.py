"""An S3-compatible server (moto) on 127.0.0.1 for the object-store cache tests.

Starts moto with authentication on, creates a user with full S3 access and one bucket, prints
one JSON line (endpoint, keys, bucket) and serves until its standard input closes.
Run with the Python of the virtual environment `.ci/run` makes (target/test-venv).
"""

import json
import logging
import os
import sys

# Every request after the first three (the user, its key, its policy) is checked against
# moto's IAM, so wrong keys are refused as S3 refuses them.
os.environ["INITIAL_NO_AUTH_ACTION_COUNT"] = "3"
os.environ.setdefault("AWS_DEFAULT_REGION", "us-east-1")

import boto3  # noqa: E402
from moto.server import ThreadedMotoServer  # noqa: E402


def main():
    # Errors only on standard error, not a line per request.
    logging.getLogger("werkzeug").setLevel(logging.ERROR)
    server = ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    endpoint = f"http://{host}:{port}"
    setup = dict(endpoint_url=endpoint, region_name="us-east-1",
                 aws_access_key_id="setup", aws_secret_access_key="setup")
    iam = boto3.client("iam", **setup)
    iam.create_user(UserName="farm")
    key = iam.create_access_key(UserName="farm")["AccessKey"]
    iam.put_user_policy(
        UserName="farm",
        PolicyName="cache",
        PolicyDocument=json.dumps({
            "Version": "2012-10-17",
            "Statement": [{"Effect": "Allow", "Action": "s3:*", "Resource": "*"}],
        }),
    )
    bucket = "ori-cache"
    s3 = boto3.client("s3", endpoint_url=endpoint, region_name="us-east-1",
                      aws_access_key_id=key["AccessKeyId"],
                      aws_secret_access_key=key["SecretAccessKey"])
    s3.create_bucket(Bucket=bucket)
    print(json.dumps({
        "endpoint": endpoint,
        "access_key_id": key["AccessKeyId"],
        "secret_access_key": key["SecretAccessKey"],
        "bucket": bucket,
    }), flush=True)
    sys.stdin.read()
    server.stop()


if __name__ == "__main__":
    main()

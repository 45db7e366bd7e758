"""Prints the gateway's address space as the table of docs/gateways.md, each variable with
the topic field it is read from: python -m drill_gateway.opcua_table"""
from drill_gateway.opcua_names import markdown_table
from drill_gateway.opcua_node import source_topics

if __name__ == "__main__":
    print(markdown_table(source_topics()))

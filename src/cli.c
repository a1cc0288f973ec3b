#include "envlight.h"
int main(void){return 0;}

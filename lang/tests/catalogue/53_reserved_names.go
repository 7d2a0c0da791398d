// Functions named like control structures or Signal cannot be declared.
package Reserved

var D1 Quadcopter

func INIT() {
	D1.Land()
}

func If() {
	D1.Arm()
}

func Signal() {
	D1.Arm()
}
